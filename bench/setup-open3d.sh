#!/usr/bin/env bash
# Installs the Open3D peer of the benchmark (PyPI open3d 0.20.0) into build/bench-venv, a venv
# on Debian's /usr/bin/python3 that also sees Debian's numpy / matplotlib. Idempotent; about
# 1.2 GB and one minute. The benchmark runs without it (it then says Open3D is not available).
#   bash bench/setup-open3d.sh [VENV_DIR]
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
VENV=${1:-build/bench-venv}
OPEN3D_VERSION=0.20.0

if [[ -x $VENV/bin/python ]] && "$VENV/bin/python" -c "import open3d, sys; sys.exit(open3d.__version__ != '$OPEN3D_VERSION')" 2>/dev/null; then
  echo "setup-open3d: open3d $OPEN3D_VERSION already in $VENV"
  exit 0
fi
/usr/bin/python3 -m venv --system-site-packages "$VENV"
"$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "open3d==$OPEN3D_VERSION"
"$VENV/bin/python" -c "import open3d; print('setup-open3d: open3d', open3d.__version__, 'in $VENV')"
