#!/usr/bin/env bash
# The wheel of `pip install .` (pyproject.toml, scikit-build-core, Debian's libtorch): built once
# with Debian's /usr/bin/python3 (`pip wheel`, build dir build/pip/, incremental), then, for
# numpy 1.x and numpy 2.x, installed with that numpy into a fresh venv of /usr/bin/python3, where
#   - `import nhnet, nhnet.distributed` works, from the venv, with the wheel's version and its
#     own models (nhnet/models/; $NHNET_MODEL is unset here);
#   - nhnet.estimate(method="nhnet", orient=None) of the first 3000 points of
#     data/sample/fandisk_noise0.6.xyz writes the same file as
#     `nhnet-cli estimate --method nhnet --orient none` (byte for byte), and method=None runs
#     NH-Net too (tests/pip/check.py);
#   - numpy 2.x only: the extra `distributed` (Dask from PyPI) installed with the wheel,
#     `python -m nhnet.distributed estimate` of the same points on a local cluster (default
#     method: NH-Net with the package's model, in the workers too) within 0.5 degrees of the CLI.
# pip needs an index with scikit-build-core, pybind11 (build isolation), numpy and Dask.
# Usage: tests/pip/run.sh [NHNET_CLI]   (default $NHNET_BUILD_DIR/cli/nhnet-cli, NHNET_BUILD_DIR
#        default <repo>/build). NHNET_PIP_KEEP=DIR keeps the wheel, venvs and outputs in DIR.
set -euo pipefail
src=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
cli=${1:-${NHNET_BUILD_DIR:-$src/build}/cli/nhnet-cli}
py=/usr/bin/python3
[[ -x $cli ]] || { echo "pip test: no nhnet-cli at $cli (build it, or pass its path)" >&2; exit 1; }
if [[ -n ${NHNET_PIP_KEEP:-} ]]; then
  tmp=$NHNET_PIP_KEEP
  rm -rf "$tmp" && mkdir -p "$tmp"
else
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
fi
unset NHNET_MODEL PYTHONPATH
export CMAKE_BUILD_PARALLEL_LEVEL=${CMAKE_BUILD_PARALLEL_LEVEL:-$(nproc)}
passed=0 failed=0 ok=0
check() {  # check NAME COMMAND...: runs COMMAND, output in $tmp/NAME.log; counts it, sets ok
  local name=$1
  shift
  if "$@" > "$tmp/$name.log" 2>&1; then
    passed=$((passed + 1)) ok=1
    echo "ok    $name${note:+: $(tail -n 1 "$tmp/$name.log")}"
  else
    failed=$((failed + 1)) ok=0
    echo "FAIL  $name"
    tail -n 30 "$tmp/$name.log" | sed 's/^/      /'
  fi
}

echo "== pip wheel (build/pip/, $CMAKE_BUILD_PARALLEL_LEVEL jobs)"
start=$SECONDS
note='' check wheel "$py" -m pip wheel --no-deps -w "$tmp/wheel" "$src"
echo "      $((SECONDS - start)) s"
whl=$(echo "$tmp"/wheel/nhnet-*.whl)
if [[ ! -f $whl ]]; then
  echo "pip: $passed passed, $((failed > 0 ? failed : 1)) failed (no wheel)"
  exit 1
fi

echo "== nhnet-cli estimate --method nhnet --orient none (the reference)"
head -n 3000 "$src/data/sample/fandisk_noise0.6.xyz" > "$tmp/in.xyz"
"$cli" estimate "$tmp/in.xyz" "$tmp/cli.xyz" --quiet --method nhnet --orient none \
  --model "$src/models/nhnet.pt"

estimate_same() {  # estimate_same VENV: the venv's normals written as nhnet-cli writes them
  "$1/bin/python" "$src/tests/pip/check.py" estimate "$tmp/in.xyz" "$1/py.xyz" &&
    { cmp "$tmp/cli.xyz" "$1/py.xyz" ||
        { "$1/bin/python" "$src/tests/pip/check.py" close "$tmp/cli.xyz" "$1/py.xyz"; false; }; }
}

for numpy in 1 2; do
  venv=$tmp/venv-numpy$numpy
  echo "== venv with numpy $numpy.x"
  if [[ $numpy == 1 ]]; then
    req=("$whl" "numpy>=1.26,<2")
  else
    req=("$whl[distributed]" "numpy>=2,<3")
  fi
  note='' check "numpy$numpy-install" \
    bash -c '"$0" -m venv "$1" && "$1/bin/python" -m pip install -q "${@:2}"' "$py" "$venv" "${req[@]}"
  ((ok)) || continue
  # From $tmp: the checkout's python/nhnet/ is not on sys.path.
  cd "$tmp"
  note=1 check "numpy$numpy-import" "$venv/bin/python" "$src/tests/pip/check.py" package "$numpy"
  note=1 check "numpy$numpy-estimate" estimate_same "$venv"
  if [[ $numpy == 2 ]]; then
    note=1 check "numpy$numpy-distributed" bash -c \
      '"$0/bin/python" -m nhnet.distributed estimate "$1/in.xyz" "$0/dist.xyz" --workers 1 \
         --orient none --quiet && "$0/bin/python" "$2" close "$1/cli.xyz" "$0/dist.xyz"' \
      "$venv" "$tmp" "$src/tests/pip/check.py"
  fi
  cd "$src"
done

echo "pip: $passed passed, $failed failed"
[[ $failed == 0 ]]
