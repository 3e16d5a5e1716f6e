#!/usr/bin/env bash
# Installs the Debian packages and configures + builds nhnet into build/ (Release, Ninja).
# Shared by scripts/demo.sh and scripts/test.sh; idempotent.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

echo "== Debian packages"
bash scripts/install-deps.sh

echo "== configure and build (build/)"
if [[ -f build/CMakeCache.txt ]]; then
  cmake -S . -B build                      # keep the generator the build dir was made with
else
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
fi
cmake --build build -j2
