#!/usr/bin/env bash
# The bad-input matrix of docs/design/reliability.md#the-bad-input-matrix, end to end through nhnet-cli: one case per row
# (case_rowNN_<what>), registered by tests/cli/CMakeLists.txt as ctest tests badinput.<case>.
# Usage: bad_input_test.sh PATH/TO/nhnet-cli CASE
#
# Every refused input is checked by `refused`: it runs nhnet-cli under a 10 s timeout and a 2 GB
# address-space limit (a hang or a huge allocation fails the test), expects the exit code, one
# error line naming the file and the problem, no output file and no temporary file left, and
# then runs it again over an existing output with --overwrite and checks that the existing file
# is untouched. Rows that are not failures (accepted inputs) check what was written instead.
# Rows 12-13 (big endian, extras), 17 and 28 (far from origin, invariances) are also covered in
# depth by tests/core/test_io.cpp and tests/core/test_invariance.cpp.
source "$(dirname "${BASH_SOURCE[0]}")/cli_test.sh"

PY=/usr/bin/python3

# An ASan build (scripts/sanitize.sh) reserves terabytes of shadow address space, so `ulimit -v`
# cannot be used there: ASan's allocation cap plays its part instead (an allocation above 2 GB
# is reported and aborts, which fails the refused-input checks just the same), and the time
# limit is 6x (ASan runs the estimator several times slower).
SANITIZED=0
# (no `ldd | grep -q`: grep quitting early SIGPIPEs ldd, which pipefail turns into "no")
if [[ $(ldd "$CLI" 2>/dev/null || true) == *libasan* ]]; then SANITIZED=1; fi

# limited ARGS...: nhnet-cli under `timeout 10` and `ulimit -v 2 GB`; sets RC; fails on a hang.
limited() {
  set +e
  if ((SANITIZED)); then
    ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}max_allocation_size_mb=2048" \
      timeout 60 "$CLI" "$@" >stdout.txt 2>stderr.txt
  else
    (ulimit -v 2097152 && exec timeout 10 "$CLI" "$@") >stdout.txt 2>stderr.txt
  fi
  RC=$?
  set -e
  echo "\$ nhnet-cli $* -> $RC (limited)"
  [[ $RC != 124 ]] || fail "nhnet-cli $* ran past its time limit (hang?)"
}

# refused CODE FILE [SUBSTRING...]: `estimate FILE` fails with CODE and one error line naming
# FILE and every SUBSTRING, creating nothing; over an existing output with --overwrite the
# output keeps its bytes.
refused() {
  local code=$1 file=$2
  shift 2
  rm -f out.ply
  limited estimate "$file" out.ply "${EXTRA_ARGS[@]}"
  [[ $RC == "$code" ]] || fail "estimate $file exited $RC, expected $code"
  one_error_line "$file" "$@"
  no_file out.ply
  no_temp_files
  echo "existing output" >out.ply
  local before
  before=$(cksum <out.ply)
  limited estimate "$file" out.ply --overwrite "${EXTRA_ARGS[@]}"
  [[ $RC == "$code" ]] || fail "estimate $file --overwrite exited $RC, expected $code"
  [[ $(cksum <out.ply) == "$before" ]] || fail "existing out.ply was modified"
  no_temp_files
  rm -f out.ply
}
EXTRA_ARGS=()

# accepted FILE OUT [ARGS...]: estimate succeeds (exit 0) within the limits.
accepted() {
  local file=$1 out=$2
  shift 2
  limited estimate "$file" "$out" --overwrite "$@"
  [[ $RC == 0 ]] || fail "estimate $file exited $RC, expected 0"
  [[ -s $out ]] || fail "$out not written"
  no_temp_files
}

# big_cloud: big.xyz, 400k points (row 25).
big_cloud() {
  awk 'BEGIN { srand(17); for (i = 0; i < 400000; i++) printf "%.6f %.6f %.6f\n", rand(), rand(), 0.001 * rand() }' >big.xyz
}

# oom_refused LIMIT_KB ARGS...: `estimate big.xyz out.ply ARGS` under `ulimit -v LIMIT_KB` is
# exit 7 with one error line naming big.xyz, no output and no temporary file.
oom_refused() {
  local limit=$1
  shift
  set +e
  (ulimit -v "$limit" && exec timeout 120 "$CLI" estimate big.xyz out.ply "$@") >stdout.txt 2>stderr.txt
  RC=$?
  set -e
  [[ $RC == 7 ]] || fail "out of memory (ulimit -v $limit $*) exited $RC, expected 7"
  one_error_line big.xyz "out of memory"
  no_file out.ply
  no_temp_files
}

PLY_XYZ='property float x\nproperty float y\nproperty float z\n'


# ---- rows ----------------------------------------------------------------------------------------

case_row01_empty_file() {
  : >empty.ply
  : >empty.xyz
  : >empty.pcd
  refused 3 empty.ply "empty file"
  refused 3 empty.xyz "empty file"
  refused 3 empty.pcd "empty file"
}

case_row02_missing_directory_permission() {
  refused 3 missing.ply "No such file or directory"
  mkdir dir.ply
  refused 3 dir.ply "Is a directory"
  gen_sphere 500 1 locked.xyz
  chmod 000 locked.xyz
  if [[ $(id -u) == 0 ]]; then
    # root reads anything: run the check as nobody (the work dir must be reachable and writable).
    command -v setpriv >/dev/null || fail "setpriv (util-linux) is needed to drop root"
    chmod 777 .
    set +e
    setpriv --reuid=65534 --regid=65534 --clear-groups -- "$CLI" estimate locked.xyz out.ply \
      >stdout.txt 2>stderr.txt
    RC=$?
    set -e
  else
    limited estimate locked.xyz out.ply
  fi
  [[ $RC == 3 ]] || fail "unreadable input exited $RC, expected 3"
  one_error_line locked.xyz "Permission denied"
  no_file out.ply
}

case_row03_wrong_magic_unknown_extension() {
  printf '\xff\xd8\xff\xe0\x00\x10JFIF\x00\x01 garbage' >photo.ply
  refused 3 photo.ply "not a PLY file" magic
  cp photo.ply photo.pcd
  refused 3 photo.pcd "not a PCD file"
  head -c 2048 /dev/urandom >blob.bin
  printf '\x00' >>blob.bin
  refused 3 blob.bin "unrecognised format"
  # Content is sniffed, not the extension: XYZ numbers in a .ply file are read (with a warning).
  gen_sphere 500 2 numbers.ply
  accepted numbers.ply out.xyz --method pca
  grep -q "warning: content is XYZ" stderr.txt || fail "no warning for XYZ content in a .ply"
}

case_row04_header_not_terminated() {
  printf "ply\nformat ascii 1.0\nelement vertex 1\n$PLY_XYZ" >noend.ply
  refused 3 noend.ply "header not terminated"
  {
    printf "ply\nformat ascii 1.0\nelement vertex 1\n$PLY_XYZ"
    for ((i = 0; i < 2000; i++)); do echo "comment padding padding padding padding padding"; done
    printf 'end_header\n1 2 3\n'
  } >huge.ply
  refused 3 huge.ply "64 KiB"
}

case_row05_bad_format_line_unknown_type() {
  local body="element vertex 1\n${PLY_XYZ}end_header\n1 2 3\n"
  printf "ply\nformat\n$body" >f0.ply
  printf "ply\nformat ascii\n$body" >f1.ply
  printf "ply\nformat ascii 2.0\n$body" >f2.ply
  printf "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n1\n" >f3.ply
  refused 3 f0.ply "bad format line" "line 2"
  refused 3 f1.ply "bad format line"
  refused 3 f2.ply "unsupported PLY version '2.0'"
  refused 3 f3.ply "unknown property type 'float128'" "line 4"
}

case_row06_fewer_rows_than_declared() {
  gen_sphere 10 4 ten.xyz
  { printf "ply\nformat ascii 1.0\nelement vertex 1000\n${PLY_XYZ}end_header\n"; cat ten.xyz; } >short.ply
  refused 3 short.ply "expected 1000 vertices, file ends after 10"
  # Same with enough trailing blank space to pass the size pre-check: still no hang.
  printf '%*s\n' 20000 '' >>short.ply
  refused 3 short.ply "expected 1000 vertices, file ends after 10"
}

case_row07_binary_truncated() {
  $PY - <<'EOF'
import struct
h = b"ply\nformat binary_little_endian 1.0\nelement vertex 100\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
body = b"".join(struct.pack("<3f", i, i, 0) for i in range(100))
open("trunc.ply", "wb").write(h + body[:-5])
EOF
  refused 3 trunc.ply "unexpected end of file at byte $(stat -c %s trunc.ply)"
  # Cut inside the last record but after a face element that the size check counts at its
  # minimum: found while reading, same message.
  $PY - <<'EOF'
import struct
h = (b"ply\nformat binary_little_endian 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
     b"element vertex 100\nproperty float x\nproperty float y\nproperty float z\nend_header\n")
body = struct.pack("<B3i", 3, 0, 1, 2) + b"".join(struct.pack("<3f", i, i, 0) for i in range(100))
open("trunc2.ply", "wb").write(h + body[:-5])
EOF
  refused 3 trunc2.ply "unexpected end of file at byte $(stat -c %s trunc2.ply)" "vertex 99 of 100"
}

case_row08_declared_size_larger_than_file() {
  $PY - <<'EOF'
h = b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty double x\nproperty double y\nproperty double z\nend_header\n"
open("huge.ply", "wb").write(h + bytes(100))
p = b"VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1000000000000\nHEIGHT 1\nPOINTS 1000000000000\nDATA binary\n"
open("huge.pcd", "wb").write(p + bytes(100))
EOF
  # Refused from the header (no allocation: the 2 GB address-space limit would turn one into
  # exit 7).
  refused 3 huge.ply "declares 1000000000000 vertices"
  refused 3 huge.pcd "declares 1000000000000 points"
}

case_row09_bad_counts() {
  local c
  for c in -1 abc 1e3 1.5 2000000000000 99999999999999999999; do
    printf "ply\nformat ascii 1.0\nelement vertex %s\n${PLY_XYZ}end_header\n1 2 3\n" "$c" >count.ply
    refused 3 count.ply "invalid element count '$c'"
  done
  # Above 2^32 but plausible: taken as it is, never truncated to 32 bits (which would be 1).
  printf "ply\nformat ascii 1.0\nelement vertex 4294967297\n${PLY_XYZ}end_header\n1 2 3\n" >count.ply
  refused 3 count.ply "expected 4294967297 vertices, file ends after 1"
}

case_row10_absurd_list_counts() {
  $PY - <<'EOF'
import struct
pts = b"".join(struct.pack("<3f", i % 7, i % 5, i % 3) for i in range(50))
h = ("ply\nformat binary_little_endian 1.0\nelement vertex 50\nproperty float x\nproperty float y\n"
     "property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n").encode()
open("list.ply", "wb").write(h + pts + struct.pack("<I", 0xFFFFFFF0) + struct.pack("<3i", 0, 1, 2))
EOF
  refused 3 list.ply "list of 4294967280 items" "runs past the end of the file"
}

case_row11_vertex_layout_errors() {
  printf "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float z\nend_header\n1 2\n" >noy.ply
  printf "ply\nformat ascii 1.0\nelement vertex 1\n${PLY_XYZ}property float x\nend_header\n1 2 3 4\n" >dup.ply
  printf "ply\nformat ascii 1.0\nproperty float x\nelement vertex 1\nend_header\n1\n" >early.ply
  printf "ply\nformat ascii 1.0\nelement face 0\nend_header\n" >novertex.ply
  refused 3 noy.ply "no 'y' property"
  refused 3 dup.ply "duplicate property 'x'"
  refused 3 early.ply "property before any element"
  refused 3 novertex.ply "no vertex element"
}

case_row12_big_endian() {
  gen_sphere 2000 5 ref.xyz
  $PY - <<'EOF'
import struct
pts = [tuple(float(v) for v in l.split()) for l in open("ref.xyz")]
for order, name in ((">", "big"), ("<", "little")):
    h = ("ply\nformat binary_%s_endian 1.0\nelement vertex %d\nproperty double x\nproperty double y\n"
         "property double z\nproperty ushort id\nend_header\n" % (name, len(pts))).encode()
    body = b"".join(struct.pack(order + "3dH", *p, i % 65536) for i, p in enumerate(pts))
    open(name + ".ply", "wb").write(h + body)
EOF
  accepted big.ply big_out.xyzn --method pca --k 12
  accepted little.ply little_out.xyzn --method pca --k 12
  accepted ref.xyz ref_out.xyzn --method pca --k 12
  # Same points read from both byte orders and from text: identical output, bit for bit.
  cmp -s big_out.xyzn ref_out.xyzn || fail "big-endian PLY read differently from the text"
  cmp -s little_out.xyzn ref_out.xyzn || fail "little-endian PLY read differently from the text"
  # The extra property survives (PLY output keeps it).
  accepted big.ply big_out.ply --method pca --k 12 --ascii
  grep -aq "property ushort id" big_out.ply || fail "extra property 'id' lost"
}

case_row13_crlf_obj_info_extras() {
  {
    printf "ply\nformat ascii 1.0\ncomment\nobj_info scanner X\ncomment  \nelement vertex 500\n$PLY_XYZ"
    printf 'property uchar red\nproperty uchar green\nproperty uchar blue\nproperty float intensity\n'
    printf 'property float curvature\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n'
    awk 'BEGIN { srand(4); for (i = 0; i < 500; i++) printf "%.6f %.6f %.6f %d 7 9 %.2f 0.5\n", rand(), rand(), 0.01 * rand(), i % 256, i / 3 }'
  } | sed 's/$/\r/' >crlf.ply
  accepted crlf.ply out.ply --ascii --method pca
  local p
  for p in red green blue intensity curvature nx ny nz; do
    grep -aq "property .* $p\$" out.ply || fail "out.ply lacks property $p"
  done
  # Values carried: the 10th point's colour is 9 7 9 (columns x y z nx ny nz red green blue ...).
  awk '/^end_header/ { body = 1; next } body && ++n == 10 { exit !($7 == 9 && $8 == 7 && $9 == 9) }' out.ply \
    || fail "extra property values changed"
}

case_row14_nan_inf_malformed_tokens() {
  gen_sphere 1000 6 base.xyz
  # 5 % of the rows non-finite (nan, inf, 1e400 overflows to inf): counted, warned, exit 0.
  awk 'NR % 20 == 0 { print "nan 0 0"; print "inf 1 1"; next } { print }' base.xyz >nan.xyz
  sed -i '7s/.*/1e400 0 0/' nan.xyz
  local n bad
  n=$(npoints nan.xyz)
  bad=$(grep -cE 'nan|inf|e400' nan.xyz)
  accepted nan.xyz out.xyzn --method pca --k 12
  [[ $(npoints out.xyzn) == "$n" ]] || fail "point count changed"
  grep -q "warning: $bad non-finite points skipped" stderr.txt || fail "no warning with the count $bad"
  grep -q "$bad failed" stderr.txt || fail "summary does not count $bad failed points"
  # Those rows get a NaN normal, in place (order preserved).
  paste -d ' ' nan.xyz out.xyzn | awk '$1 ~ /nan|inf|e400/ && $7 != "nan" { exit 1 }' \
    || fail "a non-finite point got a normal"
  # Malformed tokens: exit 3 with the line number; never read as 0.
  printf '1 2 3\n4 5 6\n1,5 2 3\n' >comma.xyz
  printf '1 2 3\n4 5 6x\n' >trail.xyz
  refused 3 comma.xyz "malformed number '1,5'" "line 3"
  refused 3 trail.xyz "malformed number '6x'" "line 2"
  printf "ply\nformat ascii 1.0\nelement vertex 3\n${PLY_XYZ}end_header\n1 2 3\n4 5 6\n7 8 9 junk\n" >junk.ply
  refused 3 junk.ply "too many values" "line 10"
}

case_row15_pcd_errors() {
  local head='VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n'
  printf "$head" >headonly.pcd
  printf "${head}WIDTH 5\nHEIGHT 2\nPOINTS 5\nDATA ascii\n" >wh.pcd
  printf 'VERSION .7\nFIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 1\nDATA ascii\n1 2 3\n' >size.pcd
  printf "${head}WIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA binary_compressed\n\xff\xff\xff\x00\x24\x00\x00\x00abc" >lzf.pcd
  printf "${head}WIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA binary_compressed\n\x04\x00\x00\x00\x00\x00\x00\xf0abcd" >lzf2.pcd
  refused 3 headonly.pcd "header not terminated"
  refused 3 wh.pcd "POINTS 5 does not match WIDTH*HEIGHT 5*2"
  refused 3 size.pcd "FIELDS has 3 entries but SIZE has 2"
  refused 3 lzf.pcd "corrupt binary_compressed"
  refused 3 lzf2.pcd "corrupt binary_compressed"
}

case_row15b_sensor_pose_not_a_rotation() {
  # A sensor pose that is not a rotation (orient auto's sensor, docs/cli.md#orientation): exit 3
  # naming the file, as any malformed header.
  local head='VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 1\n'
  local pts='POINTS 3\nDATA ascii\n0 0 1\n1 0 1\n0 1 1\n'
  printf "${head}VIEWPOINT 0 0 0 0 0 0 0\n${pts}" >q0.pcd
  printf "${head}VIEWPOINT 0 0 0 nan 0 0 1\n${pts}" >qnan.pcd
  printf "${head}VIEWPOINT 0 0 0 1 0 0\n${pts}" >q6.pcd
  printf "${head}VIEWPOINT 0 0 x 1 0 0 0\n${pts}" >qx.pcd
  refused 3 q0.pcd "VIEWPOINT" "not a rotation"
  refused 3 qnan.pcd "VIEWPOINT" "not a rotation"
  refused 3 q6.pcd "bad VIEWPOINT line"
  refused 3 qx.pcd "malformed VIEWPOINT value 'x'"
  local cam='element camera 1\nproperty float view_px\nproperty float view_py\nproperty float view_pz\n'
  cam+='property float x_axisx\nproperty float x_axisy\nproperty float x_axisz\n'
  printf "ply\nformat ascii 1.0\nelement vertex 3\n${PLY_XYZ}${cam}end_header\n0 0 1\n1 0 1\n0 1 1\n1 2 3 0 0 0\n" >axes.ply
  refused 3 axes.ply "PLY camera" "not a rotation"
  # A sensor position that is not finite; a camera row cut short (ascii, binary) or missing.
  printf "${head}VIEWPOINT inf 0 0 1 0 0 0\n${pts}" >tinf.pcd
  refused 3 tinf.pcd "PCD VIEWPOINT" "sensor position is not finite"
  cam='element camera 1\nproperty float view_px\nproperty float view_py\nproperty float view_pz\n'
  local ply="ply\nformat ascii 1.0\nelement vertex 3\n${PLY_XYZ}${cam}end_header\n0 0 1\n1 0 1\n0 1 1\n"
  printf "${ply}nan 0 0\n" >campos.ply
  printf "${ply}1 2\n" >camshort.ply
  printf "${ply}" >camgone.ply
  refused 3 campos.ply "PLY camera" "sensor position is not finite"
  refused 3 camshort.ply "too few values in camera 0 of 1" "line 15"
  refused 3 camgone.ply "expected 1 cameras, file ends after 0"
  { printf "ply\nformat binary_little_endian 1.0\nelement vertex 3\n${PLY_XYZ}${cam}end_header\n"
    $PY -c "import struct,sys; sys.stdout.buffer.write(struct.pack('<10f', 0,0,1, 1,0,1, 0,1,1, 1))"
  } >cambin.ply
  refused 3 cambin.ply "element 'camera' declares 1 cameras" "unexpected end of file"
}

case_row16_xyz_ragged_header_blank() {
  printf '1 2 3\n4 5 6\n7 8\n' >ragged.xyz
  printf 'x y z\n1 2 3\n' >header.xyz
  refused 3 ragged.xyz "ragged line" "line 3"
  refused 3 header.xyz "malformed number 'x'" "line 1"
  # Blank lines and comments are skipped.
  gen_sphere 300 7 pts.xyz
  { echo "# scan"; awk '{ print; if (NR % 10 == 0) print "" }' pts.xyz; } >blank.xyz
  accepted blank.xyz out.xyzn --method pca
  [[ $(npoints out.xyzn) == 300 ]] || fail "blank lines changed the point count"
}

case_row17_far_from_origin_coordinates_kept() {
  # UTM-scale coordinates with millimetre decimals: the written x y z are the input's, digit for
  # digit (shortest round-trip text), and the normals equal those of the cloud at the origin.
  gen_sphere 2000 8 unit.xyz
  awk '{ printf "%.3f %.3f %.3f\n", 500000 + 100 * $1, 5000000 + 100 * $2, 100 * $3 }' unit.xyz >utm.xyz
  awk '{ printf "%.3f %.3f %.3f\n", 100 * $1, 100 * $2, 100 * $3 }' unit.xyz >origin.xyz
  accepted utm.xyz utm.xyzn --method pca --k 12
  # (awk parses both texts to the same double only when they denote the same double)
  paste -d ' ' utm.xyz utm.xyzn | awk '{ for (i = 1; i <= 3; i++) if ($i + 0 != $(i + 3) + 0) exit 1 }' \
    || fail "coordinates changed on the way through"
  accepted origin.xyz origin.xyzn --method pca --k 12
  # 1e-4 degree: the only difference is the rounding of 1e-3-step decimals at two magnitudes.
  expect 0 eval utm.xyzn origin.xyzn
  approx "$(eval_value mean)" 0 1e-4
}

case_row18_all_points_non_finite() {
  printf 'nan nan nan\ninf 0 0\n0 -inf 0\nnan 1 2\n' >nan.xyz
  refused 4 nan.xyz "only 0 finite points"
}

case_row19_some_non_finite_neighbours_unaffected() {
  gen_sphere 2000 9 clean.xyz
  awk '{ print } NR % 20 == 0 { print "nan nan nan" }' clean.xyz >dirty.xyz
  accepted clean.xyz clean.xyzn --method mfps
  accepted dirty.xyz dirty.xyzn --method mfps
  grep -q "warning: 100 non-finite points skipped" stderr.txt || fail "no non-finite warning"
  # The finite points' normals are exactly those of the clean cloud.
  grep -v '^nan' dirty.xyzn | cmp -s - clean.xyzn || fail "non-finite points changed their neighbours' normals"
}

case_row20_few_points() {
  gen_sphere 40 10 forty.xyz
  accepted forty.xyz out.xyzn
  grep -q "warning: only 40 finite points, fewer than the" stderr.txt || fail "no small-cloud warning"
  printf '0 0 0\n1 0 0\n' >two.xyz
  refused 4 two.xyz "only 2 finite points; at least 3 are needed"
  printf "ply\nformat ascii 1.0\nelement vertex 0\n${PLY_XYZ}end_header\n" >zero.ply
  refused 4 zero.ply "only 0 finite points"
}

case_row21_identical_and_duplicated_points() {
  for ((i = 0; i < 100; i++)); do echo "1.5 -2 3"; done >same.xyz
  refused 4 same.xyz "only 1 distinct finite points"
  gen_sphere 300 11 uniq.xyz
  for ((i = 0; i < 20; i++)); do cat uniq.xyz; done >dup20.xyz
  # Default MST orientation included: it sees each position once (before, 20 copies per point
  # made 300 separate k-NN parts, each with its own sign), so every copy gets the signed normal
  # of the deduplicated cloud, byte for byte.
  accepted uniq.xyz uniq.xyzn --method pca --k 16
  grep -q "orient mst (1 part, 0 completed, 0 unoriented" stderr.txt || fail "uniq: $(cat stderr.txt)"
  accepted dup20.xyz dup20.xyzn --method pca --k 16
  grep -q "5700 exact duplicate points" stderr.txt || fail "no duplicate warning"
  grep -q "orient mst (1 part, 0 completed, 0 unoriented" stderr.txt || fail "dup20: $(cat stderr.txt)"
  local i
  for ((i = 0; i < 20; i++)); do
    sed -n "$((300 * i + 1)),$((300 * i + 300))p" dup20.xyzn | cmp -s - uniq.xyzn \
      || fail "copy $i of the duplicated cloud differs from the deduplicated cloud (signs included)"
  done
  # Shuffled copies (not next to each other) too.
  awk 'BEGIN { srand(5) } { print rand(), $0 }' dup20.xyz | sort -k1,1g | cut -d' ' -f2- >shuf.xyz
  accepted shuf.xyz shuf.xyzn --method pca --k 16
  sort uniq.xyzn >u.sorted
  sort -u shuf.xyzn | cmp -s - u.sorted || fail "shuffled duplicates: normals or signs differ"
}

case_row22_line_plane_close_planes() {
  awk 'BEGIN { for (i = 0; i < 300; i++) printf "%g %g %g\n", 0.01 * i, 0.02 * i, 0.5 }' >line.xyz
  accepted line.xyz line.xyzn
  grep -q "300 failed" stderr.txt || fail "collinear points were given normals"
  grep -q "degenerate neighbourhood" stderr.txt || fail "no warning for collinear points"
  awk 'BEGIN { srand(12); for (i = 0; i < 3000; i++) printf "%.17g %.17g 0\n", rand(), rand() }' >plane.xyz
  # The geometric stage gives a perfect plane exact normals; NH-Net (the default) adds its
  # network's constant correction on a flat patch (measured 0.22 deg for the shipped model;
  # removing it at export cost 0.1 deg of mean error on the benchmark subset, docs/design/decisions.md#keep-the-networks-constant-correction-on-flat-patches).
  accepted plane.xyz plane.xyzn --method mfps
  awk '!($4 == 0 && $5 == 0 && ($6 == 1 || $6 == -1)) { exit 1 }' plane.xyzn || fail "plane normals are not exactly +-z"
  accepted plane.xyz plane_nh.xyzn
  awk '{ if ($6 * $6 < 0.99996) exit 1 }' plane_nh.xyzn || fail "NH-Net tilts a plane's normals by more than 0.5 deg"
  awk 'BEGIN { srand(13); for (i = 0; i < 3000; i++) printf "%.17g %.17g %.17g\n", rand(), rand(), (i % 2) * 1e-9 }' >twin.xyz
  accepted twin.xyz twin.xyzn
}

case_row23_huge_and_mixed_magnitudes() {
  gen_sphere 2000 14 unit.xyz
  awk '{ printf "%.9e %.9e %.9e\n", 1e31 * $1, 1e31 * $2, 1e31 * $3 }' unit.xyz >huge.xyz
  accepted unit.xyz unit.xyzn --method pca --k 12
  accepted huge.xyz huge.xyzn --method pca --k 12
  grep -q " 0 failed" stderr.txt || fail "points failed at 1e31"
  # 1e-3 degree: the 1e31 file carries 10 significant digits, the unit file 9.
  expect 0 eval huge.xyzn unit.xyzn
  approx "$(eval_value mean)" 0 1e-3
  awk 'NR <= 1000 { printf "%.9e %.9e %.9e\n", 1e-12 * $1, 1e-12 * $2, 1e-12 * $3; next }
       { printf "%.9e %.9e %.9e\n", 1e12 * $1, 1e12 * $2, 1e12 * $3 }' unit.xyz >mixed.xyz
  accepted mixed.xyz mixed.xyzn
}

# Memory exhaustion (row 25, without --max-memory, which does not exist): a 400k-point cloud
# under a 60 MB address-space limit (nhnet-cli starts in under 30 MB; this run needs ~100 MB):
# exit 7 naming the file, no output, no temp file, never a crash. Not run by
# scripts/sanitize.sh: ASan's operator new aborts instead of throwing std::bad_alloc.
case_row25_out_of_memory() {
  big_cloud
  # 700 MB of address space: nhnet-cli linked with libtorch needs ~550-600 MB just to load
  # (measured: --version fails at 500 MB, runs at 600 MB); the 400k-point estimate needs more.
  oom_refused 700000
}

# Row 25 with worker threads: at 900 MB the 400k-point estimate fails in its second neighbour
# search, where Eigen's resize() used to free the probe's table and leave the freed pointer
# behind (double free: SIGSEGV, exit 139, with 2 threads); a std::bad_alloc inside an OpenMP
# region ends in std::terminate unless it is carried out of the region. 1, 2 and 4 threads:
# exit 7 naming the file, no output, no temp file.
case_row25_out_of_memory_threads() {
  big_cloud
  local t
  for t in 1 2 4; do oom_refused 900000 --threads $t; done
}

# Model file faults (issue 9 item 3): a missing, empty, truncated, corrupt or mismatched model
# (tests/data/nhnet_tiny_v0.pt: descriptor version 0), or a directory, is exit 5 with one error
# line naming the model file and the problem, before the input is read (the input here does not
# exist: reading it first would be exit 3). --device cuda without CUDA is exit 8.
case_model_faults() {
  local tiny=$SRC/tests/data/nhnet_tiny.pt
  local size
  size=$(stat -c %s "$tiny")
  : >empty.pt
  head -c $((size / 2)) "$tiny" >half.pt
  head -c $((size - 100)) "$tiny" >cut.pt
  head -c 30000 /dev/urandom >random.pt
  { head -c 20000 "$tiny"; head -c 5000 /dev/zero; tail -c +25001 "$tiny"; } >zeroed.pt
  mkdir model-dir.pt
  local m
  for m in missing.pt:"no NH-Net model" empty.pt:"cannot load" half.pt:"cannot load" \
    cut.pt:"cannot load" random.pt:"cannot load" zeroed.pt: model-dir.pt:"cannot load" \
    "$SRC/tests/data/nhnet_tiny_v0.pt":descriptor_version; do
    local path=${m%%:*} what=${m#*:}
    for input in no-such-input.xyz; do
      rm -f out.ply
      limited estimate "$input" out.ply --method nhnet --model "$path"
      [[ $RC == 5 ]] || fail "model $path exited $RC, expected 5"
      one_error_line "$path" "$what"
      no_file out.ply
      no_temp_files
    done
  done
  gen_sphere 500 21 in.xyz
  limited estimate in.xyz out.ply --method nhnet --model "$tiny" --device cuda
  [[ $RC == 8 ]] || fail "--device cuda without CUDA exited $RC, expected 8"
  one_error_line "--device cuda" "no CUDA"
  no_file out.ply
  limited estimate in.xyz out.ply --method nhnet --model "$tiny"
  [[ $RC == 0 ]] || fail "the tiny model exited $RC"
  grep -q '^nhnet-cli: NH-Net runs on cpu (--device auto)$' stderr.txt \
    || fail "--device auto does not say which device: $(cat stderr.txt)"
}

# Batch runs (issue 9 item 4): three good clouds, a missing file, a garbage file and a 2-point
# cloud, as files and as a directory: the good ones are written, each bad one prints its error
# line, a summary names the failures, exit 10; --report records every input; --fail-fast stops
# at the first failure and reports the rest as skipped.
case_batch_runs() {
  mkdir in out out2 out3
  gen_sphere 800 31 in/a.xyz
  gen_sphere 800 32 in/b.xyz
  gen_sphere 800 33 c.xyz
  printf 'this is not a cloud\n' >in/garbage.xyz
  printf '0 0 0\n1 1 1\n' >in/two.xyz
  echo "not a cloud either" >in/notes.md  # not a cloud extension: not taken from the directory
  limited estimate in c.xyz missing.xyz -o out --report report.json --threads 2 --method mfps
  [[ $RC == 10 ]] || fail "batch with bad inputs exited $RC, expected 10"
  local f
  for f in a b c; do
    [[ $(awk 'NF == 6' "out/$f.xyz" | wc -l) == 800 ]] || fail "out/$f.xyz is not 800 points with normals"
  done
  no_file out/garbage.xyz
  no_file out/two.xyz
  no_file out/notes.md
  no_temp_files out
  [[ $(grep -c '^nhnet-cli: error: ' stderr.txt) == 3 ]] || fail "expected 3 error lines: $(cat stderr.txt)"
  grep -q '^nhnet-cli: error: .*in/garbage.xyz' stderr.txt || fail "garbage.xyz not named"
  grep -q '^nhnet-cli: error: in/two.xyz: only 2 finite points' stderr.txt || fail "two.xyz not named"
  grep -q '^nhnet-cli: error: .*missing.xyz.*No such file' stderr.txt || fail "missing.xyz not named"
  tail -n 1 stderr.txt | grep -q '^nhnet-cli: batch: 6 inputs, 3 ok, 3 failed; failed: in/garbage.xyz (exit 3), in/two.xyz (exit 4), missing.xyz (exit 3)$' \
    || fail "bad summary line: $(tail -n 1 stderr.txt)"
  "$PY" - report.json <<'PYEOF' || fail "bad report: $(cat report.json)"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["inputs"] == 6 and r["ok"] == 3 and r["failed"] == 3 and r["not_run"] == 0, r
assert r["method"] == "mfps" and r["device"] == "-" and r["precision"] == "-" and r["model"] is None and r["nhnet_version"]
by = {f["input"]: f for f in r["files"]}
assert [f["input"] for f in r["files"]] == ["in/a.xyz", "in/b.xyz", "in/garbage.xyz", "in/two.xyz", "c.xyz", "missing.xyz"], by
for name in ("in/a.xyz", "in/b.xyz", "c.xyz"):
    f = by[name]
    assert f["status"] == "ok" and f["exit_code"] == 0 and f["points"] == 800 and f["invalid"] == 0, f
    assert f["error"] is None and f["seconds"] > 0, f
assert by["in/two.xyz"]["exit_code"] == 4 and by["in/two.xyz"]["points"] == 2, by["in/two.xyz"]
assert by["in/garbage.xyz"]["exit_code"] == 3 and by["in/garbage.xyz"]["status"] == "failed"
assert "No such file" in by["missing.xyz"]["error"] and by["missing.xyz"]["points"] is None
PYEOF
  # Existing outputs without --overwrite are per-file failures too; --fail-fast stops there.
  limited estimate in/a.xyz in/b.xyz c.xyz -o out --fail-fast --report report2.json
  [[ $RC == 10 ]] || fail "--fail-fast exited $RC, expected 10"
  [[ $(grep -c '^nhnet-cli: error: ' stderr.txt) == 1 ]] || fail "expected 1 error line: $(cat stderr.txt)"
  grep -q '^nhnet-cli: error: in/a.xyz: out/a.xyz already exists' stderr.txt || fail "no 'already exists' error"
  tail -n 1 stderr.txt | grep -q '3 inputs, 0 ok, 1 failed, 2 not run' || fail "bad summary: $(tail -n 1 stderr.txt)"
  "$PY" -c 'import json, sys; r = json.load(open(sys.argv[1])); assert [f["status"] for f in r["files"]] == ["failed", "skipped", "skipped"], r' report2.json \
    || fail "bad --fail-fast report: $(cat report2.json)"
  # All good, NH-Net: exit 0, model loaded once, its SHA-256 and device in the report; --ext.
  local tiny=$SRC/tests/data/nhnet_tiny.pt
  limited estimate in/a.xyz c.xyz -o out2 --ext ply --method nhnet --model "$tiny" --report r3.json
  [[ $RC == 0 ]] || fail "all-good nhnet batch exited $RC"
  [[ -s out2/a.ply && -s out2/c.ply ]] || fail "--ext ply outputs missing"
  [[ $(grep -c 'NH-Net runs on' stderr.txt) == 1 ]] || fail "model loaded more than once?"
  local sha
  sha=$(sha256sum "$tiny" | cut -d' ' -f1)
  "$PY" -c 'import json, sys; r = json.load(open(sys.argv[1])); assert r["model_sha256"] == sys.argv[2] and r["device"] == "cpu" and r["precision"] == "float32" and r["ok"] == 2, r' r3.json "$sha" \
    || fail "bad nhnet report: $(cat r3.json)"
  # A bad model stops the batch before any input is read (exit 5); usage errors are exit 2.
  limited estimate in -o out3 --method nhnet --model missing.pt
  [[ $RC == 5 ]] || fail "batch with a missing model exited $RC, expected 5"
  [[ -z $(ls out3) ]] || fail "out3 is not empty"
  limited estimate in/a.xyz in/b.xyz c.xyz
  [[ $RC == 2 ]] || fail "three paths without -o exited $RC, expected 2"
  only_error_line "-o DIR"
  limited estimate in/a.xyz -o no-such-dir
  [[ $RC == 6 ]] || fail "-o missing dir exited $RC, expected 6"
  only_error_line "no-such-dir"
}

# SIGTERM / SIGINT during a batch: the outputs completed before stay intact, the interrupted one
# and the rest are not written, no temporary file is left, the report says so, exit 143 / 130.
case_batch_interrupt() {
  mkdir out
  gen_sphere 1000 41 a.xyz
  gen_sphere 1000 42 b.xyz
  gen_sphere 300000 43 big.xyz
  gen_sphere 1000 44 z.xyz
  local sig
  for sig in TERM INT; do
    rm -f out/* report.json
    if [[ $sig == INT ]] && sigint_ignored; then
      echo "SIGINT is ignored in this environment; SIGINT part skipped"
      continue
    fi
    set -m
    "$CLI" estimate a.xyz b.xyz big.xyz z.xyz -o out --threads 1 --report report.json \
      >stdout.txt 2>stderr.txt &
    local pid=$!
    set +m
    local i
    for ((i = 0; i < 3000; i++)); do
      [[ -e out/b.xyz ]] && break
      sleep 0.01
    done
    [[ -e out/b.xyz ]] || { kill -KILL "$pid" 2>/dev/null || true; fail "out/b.xyz never written"; }
    sleep 0.3
    kill -"$sig" "$pid"
    set +e
    wait "$pid"
    RC=$?
    set -e
    local want=$([[ $sig == INT ]] && echo 130 || echo 143)
    [[ $RC == "$want" ]] || fail "SIG$sig during a batch: exit $RC, expected $want"
    one_error_line interrupted
    local f
    for f in a b; do
      [[ $(awk 'NF == 6' "out/$f.xyz" | wc -l) == 1000 ]] || fail "out/$f.xyz damaged"
    done
    no_file out/big.xyz
    no_file out/z.xyz
    no_temp_files out
    no_temp_files
    "$PY" -c 'import json, sys; r = json.load(open(sys.argv[1])); assert [f["status"] for f in r["files"]] == ["ok", "ok", "interrupted", "skipped"], r' report.json \
      || fail "bad report after SIG$sig: $(cat report.json)"
  done
}

# Row 24: a far isolated outlier and two disconnected spheres. The outlier gets a normal from
# its (expanded) k-neighbourhood and disturbs nobody: the other points' normals are those of the
# cloud without it (1e-4 degree: only the recentring in double differs); orientation runs per
# connected part, reports the part count, and turns each sphere outward.
case_row24_far_outlier_disconnected_components() {
  gen_sphere 2000 24 s1.xyz
  awk '{ printf "%.9g %.9g %.9g\n", $1 + 10, $2, $3 }' s1.xyz >s2.xyz
  cat s1.xyz s2.xyz >two.xyz
  { cat two.xyz; echo "1000 1000 1000"; } >outlier.xyz
  accepted two.xyz two.xyzn --method pca --k 16
  grep -q "orient mst (2 parts, 0 completed, 0 unoriented" stderr.txt || fail "two spheres: $(cat stderr.txt)"
  accepted outlier.xyz outlier.xyzn --method pca --k 16
  grep -q "4001 points, 0 failed" stderr.txt || fail "the outlier failed or disturbed: $(cat stderr.txt)"
  # CGAL seeds a part's tree at its highest point (here the outlier) and leaves the sphere it
  # cannot reach by its own k-NN graph unoriented; the completion over the symmetric k-NN graph
  # orients it ("2000 completed"), none is left unoriented.
  grep -Eq "orient mst \(2 parts, [0-9]+ completed, 0 unoriented" stderr.txt || fail "outlier: $(cat stderr.txt)"
  head -n 4000 outlier.xyzn >rest.xyzn
  expect 0 eval rest.xyzn two.xyzn
  approx "$(eval_value mean)" 0 1e-4
  approx "$(eval_value rms)" 0 1e-4
  # Outward on both spheres (centres 0 and 10 on x): (p - c) . n > 0 for every point.
  awk 'NR <= 4000 { c = NR <= 2000 ? 0 : 10; if (($1 - c) * $4 + $2 * $5 + $3 * $6 <= 0) bad++ }
       END { exit bad > 0 }' outlier.xyzn || fail "a sphere is not oriented outward"
}

# denoise names the file on exit 4 like estimate (naming_file in cli/errors.hpp): too few points
# for the estimate, and no point with a valid normal with --normals-from input.
case_denoise_unprocessable_names_the_file() {
  printf '0 0 0\n1 1 1\n' >two.xyz
  limited denoise two.xyz out.xyz
  [[ $RC == 4 ]] || fail "denoise of 2 points exited $RC, expected 4"
  one_error_line "two.xyz: only 2 finite points"
  no_file out.xyz
  printf '0 0 0 nan nan nan\n1 0 0 nan nan nan\n0 1 0 nan nan nan\n' >nonormal.xyzn
  limited denoise nonormal.xyzn out.xyzn --normals-from input
  [[ $RC == 4 ]] || fail "denoise without valid normals exited $RC, expected 4"
  one_error_line "nonormal.xyzn: "
  no_file out.xyzn
  no_temp_files
}

case_row26_bad_parameters() {
  gen_sphere 500 15 in.xyz
  local args
  for args in "--k 0" "--k -3" "--k nan" "--k inf" "--k 1e3" "--scales nan" "--scales 50,-1" \
    "--threads nan" "--seed 1.5" "--radius 0.1"; do
    # shellcheck disable=SC2086
    limited estimate in.xyz out.ply $args
    [[ $RC == 2 ]] || fail "estimate $args exited $RC, expected 2"
    only_error_line
    no_file out.ply
  done
}

case_row27_output_paths() {
  gen_sphere 500 16 in.xyz
  local before
  before=$(cksum <in.xyz)
  limited estimate in.xyz in.xyz --overwrite
  [[ $RC == 6 ]] || fail "output = input exited $RC"
  only_error_line "refusing to overwrite the input" in.xyz
  [[ $(cksum <in.xyz) == "$before" ]] || fail "input modified"
  limited estimate in.xyz missing/out.ply
  [[ $RC == 6 ]] || fail "missing directory exited $RC"
  only_error_line missing "does not exist"
  echo old >exists.ply
  limited estimate in.xyz exists.ply
  [[ $RC == 6 ]] || fail "existing output exited $RC"
  only_error_line exists.ply --overwrite
  [[ $(cat exists.ply) == old ]] || fail "existing output modified"
  mkdir ro
  chmod 555 ro
  if [[ $(id -u) == 0 ]]; then
    chmod 777 .
    set +e
    setpriv --reuid=65534 --regid=65534 --clear-groups -- "$CLI" estimate in.xyz ro/out.ply \
      >stdout.txt 2>stderr.txt
    RC=$?
    set -e
  else
    limited estimate in.xyz ro/out.ply
  fi
  [[ $RC == 6 ]] || fail "read-only directory exited $RC"
  only_error_line ro/out.ply "Permission denied"
  no_file ro/out.ply
  chmod 755 ro
}

case_row29_las_laz_e57_malformed() {
  # LAS/LAZ from laspy (+ lazrs), E57 from pye57 (scripts/install-deps.sh), then broken.
  $PY - <<'EOF2'
import struct
import numpy as np, laspy, pye57
h = laspy.LasHeader(point_format=3, version="1.4")
h.scales = [0.001] * 3
h.offsets = [500000, 4000000, 0]
las = laspy.LasData(h)
rng = np.random.default_rng(0)
las.x, las.y, las.z = 500000 + rng.uniform(0, 9, 200), 4000000 + rng.uniform(0, 9, 200), rng.uniform(0, 1, 200)
las.write("ok.las")
las.write("ok.laz")
b = open("ok.las", "rb").read()
open("trunc.las", "wb").write(b[:-7])
open("head.las", "wb").write(b[:120])
lie = bytearray(b); lie[247:255] = struct.pack("<Q", 1 << 40); lie[107:111] = struct.pack("<I", 0)
open("lie.las", "wb").write(bytes(lie))
fmt = bytearray(b); fmt[104] = 12
open("fmt.las", "wb").write(bytes(fmt))
z = open("ok.laz", "rb").read()
open("trunc.laz", "wb").write(z[:len(z) // 2])
e = pye57.E57("pose.e57", mode="w")
p = rng.uniform(0, 1, (50, 3))
e.write_scan_raw({"cartesianX": p[:, 0].copy(), "cartesianY": p[:, 1].copy(), "cartesianZ": p[:, 2].copy()},
                 name="tilted", rotation=np.array([2.0, 0, 0, 0]), translation=np.zeros(3))
e.close()
e57 = open("pose.e57", "rb").read()
open("trunc.e57", "wb").write(e57[:len(e57) // 2])
for name, at, value in [("ver", 25, bytes([9])), ("scale", 131, struct.pack("<d", 0.0)),
                        ("novlr", 104, bytes([b[104] | 0x80])), ("reclen", 105, struct.pack("<H", 20)),
                        ("offset", 96, struct.pack("<I", len(b) + 10))]:
    broken = bytearray(b); broken[at:at + len(value)] = value
    open(name + ".las", "wb").write(bytes(broken))
open("magic.e57", "wb").write(b"ASTM-E57" + bytes(2040))
open("notmagic.e57", "wb").write(b"not an e57 file\n" * 40)
EOF2
  refused 3 trunc.las "header declares 200 points" "truncated?"
  refused 3 head.las "truncated LAS header"
  refused 3 lie.las "header declares 1099511627776 points"
  refused 3 fmt.las "unknown LAS point format 12"
  refused 3 trunc.laz "LAZ"
  refused 3 trunc.e57 "E57"
  refused 3 pose.e57 "scan 'tilted'" "not a rotation"
  refused 3 ver.las "unsupported LAS version 1.9"
  refused 3 scale.las "bad scale or offset of coordinate X"
  refused 3 novlr.las "compressed points (LAZ) without a laszip VLR"
  refused 3 reclen.las "point record length 20 is shorter than point format 3 needs (34)"
  refused 3 offset.las "offset to point data" "lies outside the file"
  refused 3 magic.e57 "E57: "
  refused 3 notmagic.e57 "not an E57 file (bad magic"
  # LAZ sizes the laz crate would allocate before reading (fuzz/regressions/las): refused first.
  cp "$NHNET_SOURCE_DIR/fuzz/regressions/las/laz_layer_size_4gib.laz" layer.laz
  cp "$NHNET_SOURCE_DIR/fuzz/regressions/las/laz_chunk_count_4g.laz" chunks.laz
  refused 3 layer.laz "LAZ: a compressed layer of 4294901770 bytes" "larger than the file"
  refused 3 chunks.laz "LAZ: chunk table declares 4294967280 chunks"
  # The intact files are read (LAS -> LAS and LAZ -> PLY).
  accepted ok.las out.las --method pca
  accepted ok.laz out.ply --method pca
}

run_case
