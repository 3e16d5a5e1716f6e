#!/usr/bin/env bash
# The project's C++ formatting (.clang-format, clang-format-14 from scripts/install-deps.sh).
#   bash scripts/format.sh          reformat every tracked C++ file in place
#   bash scripts/format.sh --check  list the files that differ and exit 1 if any (CI)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
mapfile -t files < <(git ls-files '*.cpp' '*.hpp' '*.h' '*.hpp.in')
if [[ ${1:-} == --check ]]; then
  bad=()
  for f in "${files[@]}"; do
    clang-format-14 --dry-run --Werror "$f" >/dev/null 2>&1 || bad+=("$f")
  done
  if ((${#bad[@]})); then
    echo "format: ${#bad[@]} file(s) differ from .clang-format (run: bash scripts/format.sh):" >&2
    printf '  %s\n' "${bad[@]}" >&2
    exit 1
  fi
  echo "format: ${#files[@]} C++ files follow .clang-format"
else
  clang-format-14 -i "${files[@]}"
fi
