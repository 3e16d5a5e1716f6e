# The 10M-point cases of meshlab_test.sh (sourced by it with "large", ctest label large): a
# complete run through meshlabserver with peak memory bounded, and a cancelled one.
LARGE_N=10000000
/usr/bin/python3 "$SRC/tests/cloudcompare/make_clouds.py" big big.ply "$LARGE_N"
peak_mib() { awk -F': ' '/Maximum resident set size/ { print int($2 / 1024) }' time.txt; }
# mls_timed ARGS...: meshlabserver under /usr/bin/time -v (time.txt).
mls_timed() { /usr/bin/time -v -o time.txt "$T/ml/meshlabserver" "$@" >"$T/last.log" 2>&1; }

# Complete run: PCA (the complete default NH-Net would take ~20 min on CI's 2 cores) and
# viewpoint orientation (O(N)), no output file (writing 10M points is not the plugin's part).
# Peak memory: measured 2100 MiB (MeshLab's own mesh of 10M vertices, the plugin's double
# copies of points and normals, 0.48 GB, the core's tiles of 1M points); the bound of 4 GiB, a
# sixth of this 24 GiB machine, fails if the run holds about eight more double copies of the
# cloud (0.24 GB each) or stops tiling. Progress: meshlabserver prints the stage names the
# plugin passes to MeshLab's callback.
estimate_mlx 1 0 auto 1 "" 'x="50" y="50" z="100"' | script >big.mlx
if mls_timed -i big.ply -s big.mlx; then
  peak=$(peak_mib)
  if grep -q "NH-Net: normals of $LARGE_N vertices (0 failed), method pca" last.log &&
    grep -q "neighbours" last.log && ((peak < 4096)); then
    pass "$LARGE_N points, complete (PCA), progress shown, peak $peak MiB (< 4096)"
  else
    fail "$LARGE_N points: peak $peak MiB (want < 4096), log:"; tail -c 2000 last.log
  fi
else
  fail "$LARGE_N points: meshlabserver exited $?"; tail -c 2000 last.log
fi

# Cancelled once the progress reaches 5 % (NHNET_PLUGIN_CANCEL_AT, the test hook of the
# plugin's cancel path, which the GUI's Cancel button and a false from MeshLab's callback take
# too): meshlabserver's failed-filter exit, the cancel message, no output, and the core stopped
# within 3 s of the cancel (measured 0.66 s with this machine's 2 cores shared by ~20 busy
# processes; a core that ignored the cancel would run on for a minute or more).
rm -f cancel.ply
set +e
NHNET_PLUGIN_CANCEL_AT=0.05 mls_timed -i big.ply -o cancel.ply -s big.mlx
rc=$?
set -e
delay=$(sed -n 's/.*stopped \([0-9.]*\) s after the cancel.*/\1/p' last.log | head -n 1)
if [[ $rc == 255 && ! -e cancel.ply && -n $delay ]] &&
  grep -q "NH-Net: cancelled; the layer was left unchanged" last.log &&
  awk -v d="$delay" 'BEGIN { exit !(d < 3) }'; then
  pass "cancel: exit $rc, stopped $delay s after the cancel, nothing written"
else
  fail "cancel: exit $rc (want 255), stopped '$delay' s after (want < 3), output $(ls cancel.ply 2>/dev/null)"
  tail -c 2000 last.log
fi
