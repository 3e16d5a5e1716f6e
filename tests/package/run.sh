#!/usr/bin/env bash
# ctest `package.install`: installs the build tree into a temporary prefix and uses it the way
# the README tells users to, with the README's own code:
#   1. the outside CMake project of README.md (the blocks marked `<!-- example: FILE -->`:
#      CMakeLists.txt, estimate_file.cpp, pcl_normals.cpp) configures with find_package(nhnet),
#      builds against nhnet::core / nhnet::pcl, and computes the same normals as the installed
#      nhnet-cli (byte-identical output; the PCL example within float precision);
#   2. the README's Python script, run with the installed package, computes the same normals;
#   3. one version everywhere: the top CMakeLists.txt's project(VERSION), nhnetConfigVersion.cmake,
#      find_package's nhnet_VERSION, nhnet::version(), nhnet-cli --version, nhnet.__version__.
# Usage: run.sh BUILD_DIR SOURCE_DIR [CMAKE_GENERATOR]
set -euo pipefail
build=$1 src=$2 gen=${3:-}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
prefix=$tmp/prefix
fail() { echo "package test: $*" >&2; exit 1; }

echo "== cmake --install"
cmake --install "$build" --prefix "$prefix" > "$tmp/install.log"
for f in bin/nhnet-cli lib/libnhnet.a include/nhnet/pipeline/estimate.hpp include/nhnet/version.hpp \
         include/nhnet/pcl/normal_estimation.hpp lib/cmake/nhnet/nhnetConfig.cmake \
         lib/cmake/nhnet/nhnetConfigVersion.cmake lib/cmake/nhnet/nhnetTargets.cmake; do
  [[ -e $prefix/$f ]] || fail "not installed: $f"
done
[[ -d $prefix/share/nhnet/models ]] || fail "not installed: share/nhnet/models/"
if [[ -d $src/models ]]; then
  for f in "$src"/models/*; do
    [[ -e $f ]] || continue
    [[ -e $prefix/share/nhnet/models/$(basename "$f") ]] || fail "model file not installed: $f"
  done
fi
pydir=$(echo "$prefix"/lib/python3*/dist-packages)
[[ -f $pydir/nhnet/__init__.py ]] || fail "not installed: Python package nhnet"

# The README's example files.
mkdir -p "$tmp/project"
for name in CMakeLists.txt estimate_file.cpp pcl_normals.cpp example.py; do
  awk -v marker="<!-- example: $name -->" '
    $0 == marker { grab = 1; next }
    grab == 1 && /^```/ { grab = 2; next }
    grab == 2 && /^```/ { exit }
    grab == 2 { print }' "$src/README.md" > "$tmp/project/$name"
  [[ -s $tmp/project/$name ]] || fail "README.md has no block marked <!-- example: $name -->"
done

# Input: the first 3000 points of the bundled sample as a binary float32 PCD (exactly the same
# coordinates for PCL, which reads floats, and for nhnet, which reads them into doubles).
env -u PYTHONPATH /usr/bin/python3 - "$src/data/sample/fandisk_noise0.6.xyz" "$tmp/in.pcd" <<'PY'
import sys
import numpy as np
p = np.loadtxt(sys.argv[1], max_rows=3000, dtype=np.float32)[:, :3]
with open(sys.argv[2], "wb") as f:
    f.write(("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
             f"WIDTH {len(p)}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {len(p)}\n"
             "DATA binary\n").encode())
    f.write(np.ascontiguousarray(p, dtype="<f4").tobytes())
PY

echo "== installed nhnet-cli"
# --orient none: the library examples return unoriented normals; the CLI orients by default.
# --method mfps: the C++ library's default method (it needs no model file) and the README's
# Python example's; the CLI's and Python's default_method() is nhnet where the model is there.
"$prefix/bin/nhnet-cli" estimate "$tmp/in.pcd" "$tmp/cli.xyz" --quiet --orient none --method mfps

echo "== outside CMake project from the README"
cmake -S "$tmp/project" -B "$tmp/project/build" ${gen:+-G "$gen"} -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" > "$tmp/configure.log" 2>&1 || { cat "$tmp/configure.log"; fail "configure"; }
cmake --build "$tmp/project/build" > "$tmp/build.log" 2>&1 || { cat "$tmp/build.log"; fail "build"; }
"$tmp/project/build/estimate_file" "$tmp/in.pcd" "$tmp/lib.xyz" | tee "$tmp/lib.out"
cmp "$tmp/cli.xyz" "$tmp/lib.xyz" || fail "estimate_file and nhnet-cli normals differ"
"$tmp/project/build/pcl_normals" "$tmp/in.pcd" "$tmp/pcl.pcd"
"$prefix/bin/nhnet-cli" eval "$tmp/pcl.pcd" "$tmp/cli.xyz" --json | tee "$tmp/eval.json"
# Same normals stored as float32 (PCD) and flipped towards the viewpoint: unoriented errors of
# float rounding only, far below 0.001 degrees; every point compared.
/usr/bin/python3 -c "
import json, sys
e = json.load(open('$tmp/eval.json'))
sys.exit(0 if e['count'] == 3000 and e['invalid'] == 0 and e['mean_deg'] < 1e-3 else 1)" ||
  fail "pcl_normals and nhnet-cli normals differ"

echo "== the README's Python script with the installed package"
(cd "$tmp" && env -u PYTHONPATH PYTHONPATH="$pydir" /usr/bin/python3 "$tmp/project/example.py" \
   in.pcd py.xyz) | tee "$tmp/py.out"
cmp "$tmp/cli.xyz" "$tmp/py.xyz" || fail "Python and nhnet-cli normals differ"
env -u PYTHONPATH PYTHONPATH="$pydir" /usr/bin/python3 -c "
import nhnet, sys
assert nhnet.__file__.startswith('$pydir'), nhnet.__file__
print(nhnet.__version__)" > "$tmp/version.txt"

echo "== one version"
v_project=$(sed -n 's/^project(nhnet VERSION \([0-9.]*\).*/\1/p' "$src/CMakeLists.txt")
v_package=$(sed -n 's/^set(PACKAGE_VERSION "\(.*\)")/\1/p' "$prefix/lib/cmake/nhnet/nhnetConfigVersion.cmake")
v_found=$(sed -n 's/^-- found nhnet \([0-9.]*\).*/\1/p' "$tmp/configure.log")
v_lib=$(sed -n 's/^nhnet \([0-9.]*\):.*/\1/p' "$tmp/lib.out")
v_cli=$("$prefix/bin/nhnet-cli" --version)
v_python=$(cat "$tmp/version.txt")
echo "project=$v_project package=$v_package find_package=$v_found library=$v_lib cli='$v_cli' python=$v_python"
[[ -n $v_project && $v_package == "$v_project" && $v_found == "$v_project" &&
   $v_lib == "$v_project" && $v_cli == "nhnet-cli $v_project" && $v_python == "$v_project" ]] ||
  fail "versions disagree"
echo "package test passed"
