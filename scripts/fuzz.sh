#!/usr/bin/env bash
# Fuzzes the point cloud readers with libFuzzer (clang, ASan + UBSan):
#   bash scripts/fuzz.sh [SECONDS_PER_READER=60] [ply pcd xyz las e57]
# Builds build-fuzz/ with clang and -DNHNET_FUZZ=ON, then runs fuzz_<fmt> for SECONDS on each
# reader, starting from fuzz/corpus/<fmt> (+ the reproducers in fuzz/regressions/<fmt>). Hangs
# (-timeout=10) and allocations above 2 GB (-rss_limit_mb=2048) count as failures. New inputs go
# to build-fuzz/corpus/<fmt>; a crash is written to build-fuzz/artifacts/<fmt>/ and the script
# exits non-zero. Copy a reproducer into fuzz/regressions/<fmt>/ once fixed: the normal build
# replays it as the ctest test fuzz.replay_<fmt>.
# Needs: clang, libclang-rt-14-dev (libFuzzer), libomp-14-dev (scripts/install-deps.sh).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

seconds=${1:-60}
shift || true
formats=("$@")
((${#formats[@]})) || formats=(ply pcd xyz las e57)

if [[ ! -f build-fuzz/CMakeCache.txt ]]; then
  CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DNHNET_FUZZ=ON -DNHNET_BUILD_TESTS=OFF -DNHNET_BUILD_CLI=OFF -DNHNET_BUILD_TOOLS=OFF \
    -DNHNET_BUILD_PYTHON=OFF -DNHNET_BUILD_MESHLAB_PLUGIN=OFF -DNHNET_BUILD_CLOUDCOMPARE_PLUGIN=OFF
fi
cmake --build build-fuzz -j2 --target "${formats[@]/#/fuzz_}"

status=0
for fmt in "${formats[@]}"; do
  mkdir -p "build-fuzz/corpus/$fmt" "build-fuzz/artifacts/$fmt"
  seeds=(fuzz/corpus/"$fmt")
  [[ -d fuzz/regressions/$fmt ]] && seeds+=(fuzz/regressions/"$fmt")
  dict=()
  [[ -f fuzz/$fmt.dict ]] && dict=(-dict="fuzz/$fmt.dict")
  echo "== fuzz_$fmt for ${seconds}s"
  # One worker: the machine is shared. UBSan findings abort (halt_on_error) so they are crashes.
  if ! UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
    "build-fuzz/fuzz/fuzz_$fmt" "build-fuzz/corpus/$fmt" "${seeds[@]}" "${dict[@]}" \
      -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=16384 \
      -artifact_prefix="build-fuzz/artifacts/$fmt/" -print_final_stats=1; then
    echo "fuzz_$fmt FAILED: reproducer in build-fuzz/artifacts/$fmt/" >&2
    status=1
  fi
done
exit $status
