#!/usr/bin/env bash
# Installs the Debian packages and configures + builds nhnet into build/ (Release, Ninja).
# Shared by scripts/demo.sh and scripts/test.sh; idempotent.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

echo "== Debian packages"
bash scripts/install-deps.sh

echo "== configure and build (build/)"
# NHNET_BUILD_BENCH: the benchmark (bench/, needs PCL + CGAL from install-deps.sh) is tested too.
# NHNET_WERROR=1 (set by .ci/run): compiler warnings in nhnet's own targets are errors.
werror=-DNHNET_WARNINGS_AS_ERRORS=$([[ ${NHNET_WERROR:-0} == 1 ]] && echo ON || echo OFF)
if [[ -f build/CMakeCache.txt ]]; then
  # keep the generator the build dir was made with
  cmake -S . -B build -DNHNET_BUILD_BENCH=ON "$werror"
else
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DNHNET_BUILD_BENCH=ON "$werror"
fi
cmake --build build -j2
