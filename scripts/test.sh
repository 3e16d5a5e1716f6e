#!/usr/bin/env bash
# Runs every test of the project on a fresh Debian 12 machine (run as root, or with sudo):
#   bash scripts/test.sh
# Installs the Debian packages, builds into build/, runs ctest (C++ unit tests and CLI tests)
# and pytest on tests/python with Debian's /usr/bin/python3; builds the Debian packages
# (scripts/package.sh) and installs and uses them in a fresh Debian 12 root
# (tests/package/clean_root.sh; NHNET_SKIP_PACKAGES=1 skips both); builds the wheel of
# `pip install .` and uses it in fresh venvs (tests/pip/run.sh; NHNET_SKIP_PIP=1 skips it); then
# the ASan + UBSan build and ctest run of scripts/sanitize.sh (NHNET_SKIP_SANITIZE=1 skips it).
# With NHNET_CHECK_FORMAT=1 (CI) it also checks the C++ formatting (scripts/format.sh --check).
# Exits non-zero if anything fails.
# Safe to run again (idempotent). CI runs exactly this through .ci/run.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

echo "== 1-2/7 Debian packages, configure and build"
bash scripts/build.sh

failed=()

# NHNET_CHECK_FORMAT=1 (set by .ci/run): every tracked C++ file follows .clang-format.
if [[ ${NHNET_CHECK_FORMAT:-0} == 1 ]] && ! bash scripts/format.sh --check; then
  failed+=(format)
fi

echo "== 3/7 ctest (C++ and CLI tests)"
if ! (cd build && ctest --output-on-failure -j2); then
  failed+=(ctest)
fi

echo "== 4/7 pytest (tests/python)"
# Open3D peer of the benchmark (PyPI open3d into build/bench-venv); the benchmark and its test
# run without it and say so when it cannot be installed.
bash bench/setup-open3d.sh || echo "test: Open3D could not be installed; the benchmark runs without it"
if [[ -d tests/python ]]; then
  has_tests=$(find tests/python -type f \( -name 'test_*.py' -o -name '*_test.py' \) | head -n 1)
  set +e
  NHNET_BUILD_DIR="$PWD/build" PYTHONPATH="$PWD/build/python:$PWD/training${PYTHONPATH:+:$PYTHONPATH}" /usr/bin/python3 -m pytest tests/python -q
  rc=$?
  set -e
  if [[ $rc == 5 && -z $has_tests ]]; then
    echo "pytest: no test files in tests/python"
  elif [[ $rc != 0 ]]; then
    echo "pytest failed (exit $rc)"
    failed+=(pytest)
  fi
else
  echo "pytest: no tests/python directory; skipped"
fi

echo "== 5/7 Debian packages: scripts/package.sh, then installed in a fresh Debian 12 root"
if [[ ${NHNET_SKIP_PACKAGES:-0} == 1 ]]; then
  echo "packages: skipped (NHNET_SKIP_PACKAGES=1)"
elif ! { bash scripts/package.sh && bash tests/package/clean_root.sh build/packages; }; then
  failed+=(packages)
fi

echo "== 6/7 pip install . (the wheel in fresh venvs, numpy 1.x and 2.x: tests/pip/run.sh)"
if [[ ${NHNET_SKIP_PIP:-0} == 1 ]]; then
  echo "pip: skipped (NHNET_SKIP_PIP=1)"
elif ! bash tests/pip/run.sh build/cli/nhnet-cli; then
  failed+=(pip)
fi

echo "== 7/7 sanitizers: ASan + UBSan build, the memory tests again (scripts/sanitize.sh)"
if [[ ${NHNET_SKIP_SANITIZE:-0} == 1 ]]; then
  echo "sanitizers: skipped (NHNET_SKIP_SANITIZE=1)"
elif ! bash scripts/sanitize.sh; then
  failed+=(sanitize)
fi

if ((${#failed[@]})); then
  echo "FAILED: ${failed[*]}" >&2
  exit 1
fi
echo "ALL TESTS PASSED"
