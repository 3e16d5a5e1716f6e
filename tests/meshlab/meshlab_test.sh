#!/usr/bin/env bash
# Headless test of the MeshLab plugin with the real meshlabserver (Debian's MeshLab 2020.09):
#   meshlab_test.sh PLUGIN.so NHNET_CLI SOURCE_DIR
# meshlabserver only looks for plugins in <its own dir>/plugins (else the system dir), so a
# private copy gets a plugins/ dir with the system io_base (PLY) and filter_create (a mesh to
# test on) plus ours; XDG_CONFIG_HOME is a temp dir; xvfb-run gives it the X display it needs.
set -euo pipefail
PLUGIN=$(realpath "$1")
CLI=$(realpath "$2")
SRC=$(realpath "$3")
MLDIR=/usr/lib/x86_64-linux-gnu/meshlab

T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
mkdir -p "$T/ml/plugins" "$T/config" "$T/runtime"
chmod 700 "$T/runtime"
cp /usr/bin/meshlabserver "$T/ml/"
ln -s "$MLDIR/plugins/libio_base.so" "$MLDIR/plugins/libfilter_create.so" "$PLUGIN" "$T/ml/plugins/"
export XDG_CONFIG_HOME="$T/config" XDG_RUNTIME_DIR="$T/runtime"
export LD_LIBRARY_PATH="$MLDIR${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
cd "$T"

fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
pass() { echo "ok: $*"; }
# meshlabserver ARGS... > $T/last.log; returns its exit status.
mls() { xvfb-run -a "$T/ml/meshlabserver" "$@" >"$T/last.log" 2>&1; }

# An .mlx script running "Estimate normals (NH-Net)". meshlabserver needs every parameter, in
# the filter's order (it asserts otherwise), and enum_cardinality on enums.
# estimate_mlx METHOD K SCALES ORIENTATION  (method 0 = MFPS, 1 = PCA; orientation 0 = keep, 1 = none)
estimate_mlx() {
  cat <<MLX
  <filter name="Estimate normals (NH-Net)">
   <Param type="RichEnum" name="method" value="$1" enum_cardinality="2"/>
   <Param type="RichInt" name="k" value="$2"/>
   <Param type="RichString" name="scales" value="$3"/>
   <Param type="RichEnum" name="orientation" value="$4" enum_cardinality="2"/>
   <Param type="RichInt" name="threads" value="0"/>
   <Param type="RichInt" name="seed" value="1"/>
  </filter>
MLX
}
script() { { echo '<!DOCTYPE FilterScript>'; echo '<FilterScript>'; cat; echo '</FilterScript>'; } }

# 1. Both filters are listed.
if mls -d dump.txt && grep -q 'Estimate normals (NH-Net)' dump.txt; then
  pass "meshlabserver lists 'Estimate normals (NH-Net)'"
else
  fail "'Estimate normals (NH-Net)' not listed"; cat last.log
fi

# 2. The noisy sample as a point set: the plugin's normals equal nhnet-cli's on the same input.
# meshlabserver itself writes the binary PLY both read, so both see the same float coordinates.
sample="$SRC/data/sample/fandisk_noise0.6.xyz"
awk '{ l[n++] = $0 } END { print "ply\nformat ascii 1.0\nelement vertex " n;
       print "property float x\nproperty float y\nproperty float z\nend_header";
       for (i = 0; i < n; i++) print l[i] }' "$sample" >in_ascii.ply
mls -i in_ascii.ply -o in.ply || { cat last.log; exit 1; }
estimate_mlx 0 0 auto 1 | script >est.mlx
if mls -i in.ply -o ml.ply -m vn -s est.mlx; then
  grep 'NH-Net:' last.log || true
  "$CLI" estimate in.ply cli.ply --orient none --quiet
  # The same deterministic core on the same doubles: the only difference is rounding of the
  # normals to float32 in the two PLY writers (~1e-5 degrees), so 0.01 degrees RMS is strict.
  rms=$("$CLI" eval ml.ply cli.ply --json | sed -E 's/.*"rms_deg": *([0-9.eE+-]+).*/\1/')
  if awk -v r="$rms" 'BEGIN { exit !(r < 0.01) }'; then
    pass "sample point set: plugin vs nhnet-cli RMS $rms deg (< 0.01)"
  else
    fail "sample point set: plugin vs nhnet-cli RMS $rms deg (>= 0.01)"
  fi
else
  fail "estimate on the sample exited $?"; cat last.log
fi

# 3. A mesh's vertices: MeshLab's own sphere (2562 vertices), PCA, orientation 'keep' (the
# mesh's face-averaged vertex normals point outwards). Every normal must point outwards and be
# within 2 degrees of the radial direction: the vertices lie exactly on the sphere, and PCA over
# their uneven (subdivided icosahedron) neighbourhoods deviates a little from the radius
# (measured worst 1.06 degrees).
{ cat <<MLX
  <filter name="Sphere">
   <Param type="RichFloat" name="radius" value="1"/>
   <Param type="RichInt" name="subdiv" value="4"/>
  </filter>
MLX
  estimate_mlx 1 0 auto 0; } | script >mesh.mlx
if mls -o sphere.ply -m vn sa -s mesh.mlx; then
  read -r count worst < <(awk 'f && NF >= 6 { d = sqrt($1*$1 + $2*$2 + $3*$3) * sqrt($4*$4 + $5*$5 + $6*$6);
      c = ($1*$4 + $2*$5 + $3*$6) / d; if (c > 1) c = 1;
      a = atan2(sqrt(1 - c*c), c) * 45 / atan2(1, 1); if (a > w) w = a; n++ }
    /^end_header/ { f = 1 } END { printf "%d %.4f\n", n, w }' sphere.ply)
  if [[ $count == 2562 ]] && awk -v w="$worst" 'BEGIN { exit !(w < 2) }'; then
    pass "sphere mesh: $count vertex normals outwards, worst $worst deg from radial (< 2)"
  else
    fail "sphere mesh: $count vertices (want 2562), worst $worst deg from radial (want < 2)"
  fi
else
  fail "estimate on a mesh exited $?"; cat last.log
fi

# 4. Errors: a clear message in the log, meshlabserver's exit for a failed script (255: it calls
# exit(-1)), not a crash (134 abort, 139 segfault), and no output written.
# expect_error NAME MESSAGE_REGEX MESHLABSERVER_ARGS...
expect_error() {
  local name=$1 re=$2; shift 2
  rm -f err.ply
  set +e; mls "$@" -o err.ply -m vn; local rc=$?; set -e
  if [[ $rc == 255 ]] && grep -Eq "$re" last.log && [[ ! -e err.ply ]]; then
    pass "$name: exit $rc, $(grep -E "$re" last.log | head -n1)"
  else
    fail "$name: exit $rc (want 255), message /$re/ in the log, no output"; cat last.log
  fi
}
estimate_mlx 0 0 10,x 1 | script >bad_scales.mlx
expect_error "bad scales" "NH-Net: bad parameter: parameter 'scales': '10,x' is not" \
  -i in.ply -s bad_scales.mlx
estimate_mlx 7 0 auto 1 | script >bad_method.mlx
expect_error "method out of range" "NH-Net: bad parameter: parameter 'method': choice 7" \
  -i in.ply -s bad_method.mlx
printf 'ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n' >two.ply
expect_error "two points" "NH-Net: cannot process this layer: only 2 finite points" \
  -i two.ply -s est.mlx

if ((fails)); then
  echo "meshlab_test: $fails check(s) failed"
  exit 1
fi
echo "meshlab_test: all checks passed"
