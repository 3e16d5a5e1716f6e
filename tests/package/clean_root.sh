#!/usr/bin/env bash
# Tests nhnet's Debian packages the way a user installs them, in a truly fresh Debian 12 root:
#   bash tests/package/clean_root.sh [DEB_DIR]      (as root; DEB_DIR default build/packages)
# DEB_DIR is relative to the repo root (the script cds there). Steps:
#   1. a `debootstrap --variant=minbase bookworm` root (tests/package/lib_root.sh; the tarball is
#      cached in ~/.cache/nhnet-test-roots/, or $NHNET_ROOT_CACHE, outside the clone as pip's cache
#      is; CLEAN_ROOT_REFRESH=1 makes it again) unpacked into a temp dir under build/clean-root/ (on a
#      loop-mounted image of its own, root.XXXXXX.img, unless CLEAN_ROOT_IMAGE=0), with
#      this machine's apt sources (the mirror they name, bookworm-updates and -security; deb-src
#      entries dropped), its resolv.conf, and /proc, /sys, /dev mounted while it is used (apt's
#      downloaded .debs are kept in the same cache, apt-archives/; CLEAN_ROOT_APT_CACHE=0: not);
#   2. `apt-get install ./*.deb` of every DEB_DIR/*.deb in it (with Recommends, as users get them);
#   3. inside the root, by chroot, with no LD_LIBRARY_PATH and nothing copied but input data:
#      a. nhnet-cli runs the network (not the MFPS fallback) on the bundled sample's first 3000 points;
#      b. `import nhnet` gives the CLI's normals for the same points;
#      c. `xvfb-run -a meshlabserver` runs "Estimate normals (NH-Net)" from the installed filter;
#      d. `CloudCompare -SILENT ... -NHNET_NORMALS` runs the installed plugin;
#      e. the README's outside CMake project builds with find_package(nhnet) and gives the CLI's
#         normals;
#      f. `apt-get purge` of every installed package removes every file they listed, and leaves no
#         file named *nhnet* behind;
#   4. lintian on every .deb (on this machine): no E: line.
# Prints one line per check ("clean-root: ok ..." / "clean-root: FAIL ...") and a running
# "clean-root: N passed, M failed"; exits 1 with a one-line reason when anything failed. Full
# logs: build/clean-root/last-run/. KEEP_ROOT=1 keeps the root (unmounted) for a look afterwards.
# Needs root (debootstrap, chroot, mount) and network access to the Debian mirror.
# shellcheck disable=SC2016,SC2317  # '$1', '${Status}': for the root's shell, dpkg-query; check_* run indirectly
set -euo pipefail
# Nothing from /usr/local: the host's tools are Debian's.
export PATH=/usr/sbin:/usr/bin:/sbin:/bin LC_ALL=C
unset LD_LIBRARY_PATH PYTHONPATH PYTHONHOME

SELF=$(realpath "${BASH_SOURCE[0]}")
REPO=$(cd "$(dirname "$SELF")/../.." && pwd)
ROOT_TAG=clean-root
WORK=$REPO/build/clean-root
LOGS=$WORK/last-run
ROOT_IMAGE=${CLEAN_ROOT_IMAGE:-1}
ROOT_REFRESH=${CLEAN_ROOT_REFRESH:-0}
# shellcheck source=tests/package/lib_root.sh
source "$REPO/tests/package/lib_root.sh"
APT_ARCHIVES=""
[[ ${CLEAN_ROOT_APT_CACHE:-1} == 1 ]] && APT_ARCHIVES=$ROOT_CACHE_DIR/apt-archives
reexec_in_mount_namespace "$SELF" "$@"
cd "$REPO"
DEB_ARG=${1:-build/packages}
SAMPLE=$REPO/data/sample/fandisk_noise0.6.xyz
POINTS=3000
# The packages scripts/package.sh builds, and the check that needs each one.
EXPECTED=(nhnet-models nhnet-cli python3-nhnet libnhnet-dev meshlab-plugin-nhnet
          cloudcompare-plugin-nhnet)

T=""              # the root's /tmp/t, where the checks work (seen from here)
PASSED=0 FAILED=0 FAILED_NAMES=()
declare -A PKG_DEB=()   # package name -> its .deb in DEB_DIR

# ---- the root (tests/package/lib_root.sh) --------------------------------------------------------

# root_sh SCRIPT [ARGS...]: a bash script in the root, in /tmp/t, ARGS as $1...
root_sh() { local s=$1; shift; in_root /bin/bash -euo pipefail -c "cd /tmp/t; $s" bash "$@"; }

# ---- checks --------------------------------------------------------------------------------------

# run_check NAME FUNCTION: FUNCTION in a subshell (errexit on), its output in $LOGS/NAME.log;
# one line with the result and the running totals. A check states why it failed with `bad`.
run_check() {
  local name=$1 fn=$2 rc=0 t0 why
  t0=$(now)
  WHY=$LOGS/$name.why
  rm -f "$WHY"
  # (a background subshell: errexit stays on inside it, unlike in `if fn` or `fn ||`)
  (
    set -E
    trap 'echo "command failed (exit $?): $BASH_COMMAND" > "$WHY"' ERR
    cd "$T"   # the host-side files of a check (cmp.txt, ...) go to the root's /tmp/t too
    "$fn"
  ) > "$LOGS/$name.log" 2>&1 &
  wait $! || rc=$?
  if ((rc == 0)); then
    PASSED=$((PASSED + 1))
    say "ok $name: $(tail -n 1 "$LOGS/$name.log") ($(since "$t0") s)"
  else
    FAILED=$((FAILED + 1)) FAILED_NAMES+=("$name")
    why=$(head -n 1 "$WHY" 2>/dev/null || echo "exit $rc")
    [[ $why != "command failed"* ]] || why="$why; last output: $(tail -n 1 "$LOGS/$name.log")"
    say "FAIL $name: $why ($(since "$t0") s); log ${LOGS#"$REPO"/}/$name.log:"
    tail -n 15 "$LOGS/$name.log" | sed 's/^/    /'
  fi
  timing "check $name" "$(since "$t0")"
  say "$PASSED passed, $FAILED failed"
}
# bad REASON: inside a check, fail it with REASON.
bad() { echo "$*" > "$WHY"; echo "FAIL: $*"; exit 1; }
# need PACKAGE: the check needs PACKAGE's .deb.
need() { [[ -n ${PKG_DEB[$1]:-} ]] || bad "no $1 .deb in $DEB_DIR"; }

# The unoriented comparison of two normal sets (numpy in the root), as compare_normals.py's.
COMPARE=$REPO/tests/cloudcompare/compare_normals.py
compare_in_root() { in_root python3 - "$@" < "$COMPARE"; }

UPSTREAM_VERSION=""

# a. nhnet-cli with its defaults (but --orient none) runs NH-Net, not the MFPS fallback.
check_cli() {
  need nhnet-cli
  need nhnet-models
  root_sh 'command -v nhnet-cli; nhnet-cli --version' | tee version.txt
  [[ $(tail -n 1 version.txt) == "nhnet-cli $UPSTREAM_VERSION" ]] ||
    bad "nhnet-cli --version says '$(tail -n 1 version.txt)', the package is $UPSTREAM_VERSION"
  # (info) the BLAS torch's matrix products go through in this root
  root_sh 'update-alternatives --query libblas.so.3-x86_64-linux-gnu 2>/dev/null | sed -n "s/^Value: /libblas.so.3: /p"' || true
  local rc=0
  root_sh 'nhnet-cli estimate in.xyz cli.xyz --orient none --json > cli.json 2> cli.err' || rc=$?
  cat cli.json cli.err
  ((rc == 0)) || bad "nhnet-cli estimate exited $rc: $(tail -n 1 cli.err)"
  local method
  method=$(sed -nE 's/.*"method": *"([a-z]+)".*/\1/p' "$T/cli.json" | head -n 1)
  if grep -q 'warning: method mfps' "$T/cli.err" || [[ $method != nhnet ]]; then
    bad "nhnet-cli's default method is '$method', not nhnet: $(grep -m1 warning "$T/cli.err" || true)"
  fi
  [[ $(wc -l < "$T/cli.xyz") == "$POINTS" ]] || bad "cli.xyz has not $POINTS lines"
  echo "nhnet-cli $UPSTREAM_VERSION ran method nhnet ($(sed -nE 's/.*"device": *"([a-z]+)".*"precision": *"([a-z0-9]+)".*/on \1 in \2/p' "$T/cli.json")) on $POINTS points"
}

# b. import nhnet: the same normals as the CLI's for the same points (unoriented: the CLI's
# --orient none, nhnet.estimate's default for an array).
check_python() {
  need python3-nhnet
  [[ -s $T/cli.xyz ]] || bad "no CLI output to compare with (check cli failed)"
  root_sh 'python3 - "$1"' "$UPSTREAM_VERSION" <<'PY'
import sys
import numpy as np
import nhnet
from nhnet import _nhnet

want = sys.argv[1]
assert nhnet.__file__.startswith("/usr/lib/python3/dist-packages/nhnet/"), nhnet.__file__
assert nhnet.__version__ == want, f"nhnet.__version__ {nhnet.__version__}, the package is {want}"
name, why = _nhnet._default_method()
assert name == "nhnet", f"default method {name}: {why}"
cloud = nhnet.read("in.xyz")
r = nhnet.estimate(cloud.points)   # the default method; an array: unoriented
cli = np.loadtxt("cli.xyz")
assert cli.shape == (len(cloud.points), 6), cli.shape
assert np.abs(cli[:, :3] - cloud.points).max() < 1e-7, "the CLI's output points are not the input's"
a, b = r.normals, cli[:, 3:6]
nan_a, nan_b = np.isnan(a).any(1), np.isnan(b).any(1)
assert (nan_a == nan_b).all(), f"failed points differ: {nan_a.sum()} in Python, {nan_b.sum()} in the CLI"
a, b = a[~nan_a], b[~nan_b]
sign = np.where((a * b).sum(1) < 0, -1.0, 1.0)[:, None]
diff = np.abs(a - sign * b).max()
flipped = int((sign < 0).sum())
exact = int((a == b).all(1).sum())
print(f"import nhnet {nhnet.__version__} (default method {name}): {len(a)} normals, "
      f"max |difference| {diff:.2e} after sign alignment ({flipped} flipped), {exact} bit-identical")
sys.exit(0 if diff <= 1e-6 else 1)
PY
}

# The .mlx running "Estimate normals (NH-Net)" with method NH-Net (2) and orientation none (3):
# every parameter in the filter's order, as tests/meshlab/meshlab_test.sh's estimate_mlx.
MLX='<!DOCTYPE FilterScript>
<FilterScript>
  <filter name="Estimate normals (NH-Net)">
   <Param type="RichEnum" name="method" value="2" enum_cardinality="3"/>
   <Param type="RichInt" name="k" value="0"/>
   <Param type="RichString" name="scales" value="auto"/>
   <Param type="RichEnum" name="orientation" value="3" enum_cardinality="6"/>
   <Param type="RichPoint3f" name="viewpoint" x="0" y="0" z="0"/>
   <Param type="RichInt" name="mst_k" value="18"/>
   <Param type="RichInt" name="threads" value="0"/>
   <Param type="RichInt" name="seed" value="1"/>
   <Param type="RichString" name="model" value=""/>
   <Param type="RichEnum" name="precision" value="0" enum_cardinality="3"/>
   <Param type="RichBool" name="confidence" value="false"/>
  </filter>
</FilterScript>'

# c. xvfb-run -a meshlabserver with the installed filter: the CLI's normals on the same points.
# meshlabserver writes the binary PLY both read (the same float coordinates); the same
# deterministic core then leaves only the rounding of the normals to float32 in the two PLY
# writers (~1e-5 degrees): 0.01 degrees for every point is strict (tests/meshlab's bar is 0.01
# degrees RMS), a different method or model is degrees off.
check_meshlab() {
  need meshlab-plugin-nhnet
  root_sh 'ls -l /usr/lib/x86_64-linux-gnu/meshlab/plugins/ | grep -i nhnet' || true
  awk '{ l[n++] = $0 } END { print "ply\nformat ascii 1.0\nelement vertex " n
       print "property float x\nproperty float y\nproperty float z\nend_header"
       for (i = 0; i < n; i++) print l[i] }' "$T/in.xyz" > "$T/in_ascii.ply"
  printf '%s\n' "$MLX" > "$T/est.mlx"
  # xvfb-run's own exit status can be its clean-up's (tests/meshlab/meshlab_test.sh): the
  # meshlabserver statuses are kept in files.
  root_sh 'mkdir -p -m 700 /tmp/t/xdg
    XDG_RUNTIME_DIR=/tmp/t/xdg xvfb-run -a bash -c "
      meshlabserver -i in_ascii.ply -o in.ply > ml_convert.log 2>&1; echo \$? > ml_convert.rc
      meshlabserver -i in.ply -o ml.ply -m vn -s est.mlx > ml.log 2>&1; echo \$? > ml.rc" || true
    cat ml_convert.log ml.log'
  [[ $(cat "$T/ml_convert.rc" 2>/dev/null) == 0 ]] ||
    bad "meshlabserver (PLY conversion) exited $(cat "$T/ml_convert.rc" 2>/dev/null || echo '?')"
  [[ $(cat "$T/ml.rc" 2>/dev/null) == 0 ]] ||
    bad "meshlabserver with 'Estimate normals (NH-Net)' exited $(cat "$T/ml.rc" 2>/dev/null || echo '?'): $(grep -m1 -iE 'error|fail|nh-net' "$T/ml.log" || true)"
  grep -q 'method nhnet' "$T/ml.log" || bad "the MeshLab log does not say 'method nhnet'"
  root_sh 'nhnet-cli estimate in.ply cli_ml.ply --method nhnet --orient none --quiet'
  compare_in_root /tmp/t/ml.ply /tmp/t/cli_ml.ply --max-deg 0.01 | tee cmp.txt ||
    bad "MeshLab's normals are not within 0.01 degrees of nhnet-cli's: $(cat cmp.txt)"
  echo "meshlabserver 'Estimate normals (NH-Net)' = nhnet-cli within 0.01 deg: $(cat cmp.txt)"
}

# d. CloudCompare -SILENT with the installed plugin, as tests/cloudcompare/cc_test.sh runs it:
# the CLI's normals on CloudCompare's own save of the points, up to CloudCompare's normal
# quantisation (ccNormalCompressor: a normal is the centre of one of 8 * 4^9 cells, at most
# 0.16 degrees from the exact one): 0.25 degrees for every point, 0.1 on average (cc_test.sh's
# bounds; measured there max 0.157, mean 0.054).
check_cloudcompare() {
  need cloudcompare-plugin-nhnet
  root_sh 'mkdir -p -m 700 /tmp/t/ccxdg
    XDG_RUNTIME_DIR=/tmp/t/ccxdg QT_QPA_PLATFORM=offscreen CloudCompare -SILENT -NO_TIMESTAMP \
      -AUTO_SAVE OFF -C_EXPORT_FMT PLY -O in.xyz -NHNET_NORMALS -METHOD nhnet -ORIENT none \
      -SAVE_CLOUDS FILE cc.ply > cc.log 2>&1' ||
    { cat "$T/cc.log"; bad "CloudCompare exited non-zero: $(grep -m1 -iE 'error|nh-?net' "$T/cc.log" || true)"; }
  cat "$T/cc.log"
  grep -q 'Plugin found: NH-Net normals' "$T/cc.log" || bad "CloudCompare did not find the NH-Net plugin"
  grep -q 'method nhnet' "$T/cc.log" || bad "the CloudCompare log does not say 'method nhnet'"
  [[ -s $T/cc.ply ]] || bad "CloudCompare wrote no cc.ply"
  root_sh 'nhnet-cli estimate cc.ply cli_cc.ply --method nhnet --orient none --quiet'
  compare_in_root /tmp/t/cc.ply /tmp/t/cli_cc.ply --max-deg 0.25 --mean-deg 0.1 | tee cmp.txt ||
    bad "CloudCompare's normals are not within 0.25 (max) / 0.1 (mean) degrees of nhnet-cli's: $(cat cmp.txt)"
  echo "CloudCompare -NHNET_NORMALS = nhnet-cli within 0.25 deg: $(cat cmp.txt)"
}

# e. The README's outside CMake project (tests/package/run.sh's blocks) against the installed
# libnhnet-dev: estimate_file gives exactly nhnet-cli --method mfps --orient none's file (the
# library's default method, unoriented), pcl_normals the same normals within float precision.
check_cmake() {
  need libnhnet-dev
  local name p=$T/project
  mkdir -p "$p"
  for name in CMakeLists.txt estimate_file.cpp pcl_normals.cpp; do
    awk -v marker="<!-- example: $name -->" '
      $0 == marker { grab = 1; next }
      grab == 1 && /^```/ { grab = 2; next }
      grab == 2 && /^```/ { exit }
      grab == 2 { print }' "$REPO/README.md" > "$p/$name"
    [[ -s $p/$name ]] || bad "README.md has no block marked <!-- example: $name -->"
  done
  root_sh 'cmake -S project -B project/build -DCMAKE_BUILD_TYPE=Release > configure.log 2>&1' ||
    { cat "$T/configure.log"; bad "cmake configure of the README project failed: $(grep -m1 -A2 'CMake Error' "$T/configure.log" | tr '\n' ' ')"; }
  grep -E '^-- found nhnet' "$T/configure.log"
  grep -q "^-- found nhnet $UPSTREAM_VERSION" "$T/configure.log" || bad "find_package did not find nhnet $UPSTREAM_VERSION"
  root_sh 'cmake --build project/build -j2 > build.log 2>&1' ||
    { tail -n 40 "$T/build.log"; bad "building the README project failed: $(grep -m1 -E 'error|undefined' "$T/build.log")"; }
  # the same points as float32 binary PCD for pcl_normals (as tests/package/run.sh)
  root_sh 'python3 -c "
import numpy as np
p = np.loadtxt(\"in.xyz\", dtype=np.float32)[:, :3]
with open(\"in.pcd\", \"wb\") as f:
    f.write((\"VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH %d\nHEIGHT 1\n\"
             \"VIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA binary\n\" % (len(p), len(p))).encode())
    f.write(np.ascontiguousarray(p, dtype=\"<f4\").tobytes())"
    nhnet-cli estimate in.xyz cli_mfps.xyz --method mfps --orient none --quiet
    ./project/build/estimate_file in.xyz lib.xyz
    nhnet-cli estimate in.pcd cli_pcd.xyz --method mfps --orient none --quiet
    ./project/build/pcl_normals in.pcd pcl.pcd
    nhnet-cli eval pcl.pcd cli_pcd.xyz --json | tee eval.json'
  cmp "$T/cli_mfps.xyz" "$T/lib.xyz" || bad "estimate_file's normals differ from nhnet-cli's"
  # flipped to the viewpoint and stored as float32: unoriented float rounding only
  grep -qE '"count": *'"$POINTS"'[,}]' "$T/eval.json" &&
    grep -qE '"invalid": *0[,}]' "$T/eval.json" &&
    awk -v m="$(sed -nE 's/.*"mean_deg": *([0-9.eE+-]+).*/\1/p' "$T/eval.json")" 'BEGIN { exit !(m != "" && m < 1e-3) }' ||
    bad "pcl_normals' normals differ from nhnet-cli's: $(cat "$T/eval.json")"
  echo "find_package(nhnet $UPSTREAM_VERSION): estimate_file = nhnet-cli (byte-identical), pcl_normals = nhnet-cli (mean < 0.001 deg)"
}

# f. apt-get purge of every installed package removes every regular file they listed.
check_purge() {
  local pkgs=("${!PKG_DEB[@]}") f left=() p
  in_root apt-get purge -y "${pkgs[@]}" || bad "apt-get purge failed"
  for p in "${pkgs[@]}"; do
    if in_root dpkg-query -W -f='${Status}\n' "$p" 2>/dev/null | grep -qv 'not-installed'; then
      bad "$p is still known to dpkg after the purge: $(in_root dpkg-query -W -f='${Status}' "$p")"
    fi
  done
  while IFS= read -r f; do
    [[ -e $ROOT$f || -L $ROOT$f ]] && left+=("$f")
  done < "$LOGS/package-files.txt"
  ((${#left[@]} == 0)) || bad "${#left[@]} packaged files left after the purge: ${left[*]:0:5}"
  echo "purged ${#pkgs[@]} packages: all $(wc -l < "$LOGS/package-files.txt") packaged files are gone"
}

# f'. Nothing named *nhnet* that was not there before the install remains (byte-compiled Python
# the package does not remove, a directory left non-empty, ...).
check_leftovers() {
  local left f
  (cd "$ROOT" && find usr etc opt var/lib -xdev -iname '*nhnet*' 2>/dev/null | sed 's|^|/|' | sort) > "$LOGS/nhnet-after-purge.txt"
  left=$(comm -13 "$LOGS/nhnet-before.txt" "$LOGS/nhnet-after-purge.txt")
  if [[ -n $left ]]; then
    while IFS= read -r f; do find "$ROOT$f" -xdev | head -n 20 | sed "s|^$ROOT|  |"; done <<<"$left"
    bad "left after the purge: $(paste -sd ' ' <<<"$left")"
  fi
  echo "no file named *nhnet* left under /usr /etc /opt /var/lib"
}

# 4. lintian on every .deb: its output in the log, no E: line.
check_lintian() {
  ensure_host_tool lintian lintian
  local out errors
  out=$(lintian --tag-display-limit 0 "${PKG_DEB[@]}" 2>&1) || true
  echo "$out"
  errors=$(grep -c '^E:' <<<"$out" || true)
  ((errors == 0)) || bad "lintian: $errors E: line(s): $(grep -m1 '^E:' <<<"$out")"
  echo "lintian: no errors ($(grep -c '^W:' <<<"$out" || true) warnings, $(grep -c '^I:' <<<"$out" || true) infos)"
}

# ---- main ----------------------------------------------------------------------------------------

main() {
  local t_all t0 deb p f debs=()
  t_all=$(now)
  [[ $(id -u) == 0 ]] || die "needs root (debootstrap, chroot, mount)"
  DEB_DIR=$(realpath -m "$DEB_ARG")
  shopt -s nullglob
  debs=("$DEB_DIR"/*.deb)
  shopt -u nullglob
  ((${#debs[@]})) || die "no .deb in $DEB_DIR (bash scripts/package.sh makes them)"
  mkdir -p "$WORK"
  # one run at a time; then a root.* left by a killed run (never mounted: its mounts died with
  # its mount namespace, else see mounted_under) can go
  exec 9> "$WORK/.lock"
  flock -n 9 || die "another clean_root.sh is running (lock $WORK/.lock)"
  remove_stale_roots
  rm -rf "$LOGS"
  mkdir -p "$LOGS"
  for deb in "${debs[@]}"; do
    p=$(dpkg-deb -f "$deb" Package) || die "not a Debian package: $deb"
    PKG_DEB[$p]=$deb
  done
  # the upstream version every package carries (VERSION-RELEASE), nhnet-cli's by preference
  UPSTREAM_VERSION=$(dpkg-deb -f "${PKG_DEB[nhnet-cli]:-${debs[0]}}" Version | sed -E 's/^[0-9]+://; s/-[^-]*$//')
  say "${#debs[@]} packages in ${DEB_DIR#"$REPO"/}: ${!PKG_DEB[*]}"
  for p in "${EXPECTED[@]}"; do
    [[ -n ${PKG_DEB[$p]:-} ]] || say "WARNING: no $p package (its check will fail)"
  done

  trap cleanup EXIT
  trap 'exit 130' INT TERM HUP

  # 1. the fresh root
  t0=$(now)
  make_root
  T=$ROOT/tmp/t
  timing "root ready" "$(since "$t0")"

  # 2. the packages, as a user installs them (with Recommends)
  mkdir -p "$ROOT/tmp/debs" "$ROOT/tmp/t"
  chmod 755 "$ROOT/tmp/debs"
  cp "${debs[@]}" "$ROOT/tmp/debs/"
  chmod 644 "$ROOT"/tmp/debs/*.deb
  (cd "$ROOT" && find usr etc opt var/lib -xdev -iname '*nhnet*' 2>/dev/null | sed 's|^|/|' | sort) > "$LOGS/nhnet-before.txt"
  say "apt-get install ./*.deb (with Recommends)"
  t0=$(now)
  in_root /bin/sh -c 'cd /tmp/debs && apt-get install -y -q ./*.deb' > "$LOGS/install.log" 2>&1 ||
    { tail -n 30 "$LOGS/install.log" >&2; die "apt-get install ./*.deb failed in the fresh root (log: ${LOGS#"$REPO"/}/install.log): $(grep -m1 -E '^E:|Depends:|unmet' "$LOGS/install.log" || tail -n 1 "$LOGS/install.log")"; }
  timing "apt-get install ./*.deb" "$(since "$t0")"
  say "installed: $(grep -oE '^[0-9]+ upgraded, [0-9]+ newly installed.*' "$LOGS/install.log" | head -n 1); $(grep -m1 -E '^Need to get' "$LOGS/install.log" || true) ($(since "$t0") s)"
  for p in "${!PKG_DEB[@]}"; do
    [[ $(in_root dpkg-query -W -f='${Status}' "$p") == "install ok installed" ]] || die "$p is not installed after apt-get install"
    in_root dpkg -L "$p"
  done | sort -u | while IFS= read -r f; do
    if [[ -f $ROOT$f && ! -L $ROOT$f ]]; then echo "$f"; fi
  done > "$LOGS/package-files.txt"
  say "$(wc -l < "$LOGS/package-files.txt") regular files in the packages (${LOGS#"$REPO"/}/package-files.txt)"

  # test tools only the checks need (not part of what a user gets): an X server for
  # meshlabserver, a compiler for the outside project
  t0=$(now)
  in_root apt-get install -y -q --no-install-recommends xvfb xauth g++ make > "$LOGS/test-tools.log" 2>&1 ||
    { tail -n 20 "$LOGS/test-tools.log" >&2; die "apt-get install xvfb xauth g++ make failed in the root"; }
  timing "test tools (xvfb xauth g++ make)" "$(since "$t0")"

  # 3. checks; input data only: the sample's first POINTS points
  head -n "$POINTS" "$SAMPLE" > "$T/in.xyz"
  run_check cli check_cli
  run_check python check_python
  run_check meshlab check_meshlab
  run_check cloudcompare check_cloudcompare
  run_check cmake check_cmake
  run_check purge check_purge
  run_check leftovers check_leftovers
  # 4.
  run_check lintian check_lintian
  grep -E '^[EWIPXO]: ' "$LOGS/lintian.log" | sed 's/^/    /' || true

  timing total "$(since "$t_all")"
  say "timings: $(printf '%s; ' "${TIMINGS[@]}")"
  if ((FAILED)); then
    echo "clean-root: FAIL: $FAILED of $((PASSED + FAILED)) checks failed: ${FAILED_NAMES[*]} (logs: ${LOGS#"$REPO"/}/)" >&2
    exit 1
  fi
  say "all $PASSED checks passed"
}

main "$@"; exit  # on this line: bash reads a script while it runs it
