#!/usr/bin/env bash
# Builds the core, the CLI and every test with AddressSanitizer + UndefinedBehaviorSanitizer
# (gcc, -O1) into build-asan/ and runs the tests that exercise memory there: the core's unit
# tests, the bad-input matrix, the CLI's reading and writing of every format, the PCL-style
# class tests and the replay of the fuzz corpus and crash reproducers. Left out (they run in the
# normal build): the accuracy tests on benchmark-sized clouds, whose code paths the unit tests
# of the same stage run under ASan on small clouds, and the integration tests that run the CLI,
# an installed tree or cargo once more (NHNET_SANITIZE_ALL=1 runs the whole suite).
#   bash scripts/sanitize.sh
# Any ASan/UBSan report aborts the test that triggered it, so it fails. scripts/test.sh runs
# this after the normal tests (see CONTRIBUTING.md#test); set NHNET_SKIP_SANITIZE=1 there
# to skip it. Exit status: ctest's.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -g1"
# The Python module and the MeshLab / CloudCompare plugins are left out: they are loaded into
# uninstrumented hosts (python3, meshlab, CloudCompare), where an ASan library cannot run.
generator=()
[[ -f build-asan/CMakeCache.txt ]] || generator=(-G Ninja)
cmake -S . -B build-asan "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="-O1" \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DNHNET_BUILD_TOOLS=OFF -DNHNET_BUILD_PYTHON=OFF -DNHNET_BUILD_MESHLAB_PLUGIN=OFF \
  -DNHNET_BUILD_CLOUDCOMPARE_PLUGIN=OFF -DNHNET_CLI_TEST_TIMEOUT=1500
cmake --build build-asan -j2

# detect_leaks: the CLI and tests must not leak either. halt_on_error/abort: a report is a
# failure, not a log line. OpenMP's runtime keeps its thread pool alive at exit: not a leak of
# ours, and LSan does not report it (threads are still reachable).
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:halt_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
cd build-asan
# badinput.row25_out_of_memory(_threads) are left out: ASan's operator new aborts on exhaustion instead of
# throwing std::bad_alloc, so the exit-7 path it checks cannot run here (the normal build runs it).
skip='^badinput\.row25_out_of_memory'
if [[ ${NHNET_SANITIZE_ALL:-0} != 1 ]]; then
  # Accuracy on benchmark-sized clouds (names that state a gain, a bound or "as accurate"), the
  # whole-CLI runs but format I/O and garbage input, the install tree (package.*), cargo (rust.*).
  skip+='|Lowers|Beats|Accura|Gain|CostsLittle|OnTheBenchmarkSample|PreparedPointsServeTheEstimate'
  skip+='|^package\.|^rust\.'
  cli_runs=$(ctest -N | sed -n 's/^ *Test *#[0-9]*: //p' | grep -E '^cli\.' |
             grep -Ev '^cli\.(estimate_formats|garbage_input)$' | sed 's/[.]/\\./g' | paste -sd'|')
  [[ -z $cli_runs ]] || skip+="|^(${cli_runs})\$"
  echo "sanitize: $(ctest -N -E "$skip" | sed -n 's/^Total Tests: //p') of $(ctest -N |
    sed -n 's/^Total Tests: //p') tests (NHNET_SANITIZE_ALL=1: all)"
fi
ctest --output-on-failure -j2 --timeout 900 -E "$skip"
