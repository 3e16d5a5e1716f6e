#!/usr/bin/env bash
# One-command demo on a fresh Debian 12 machine (run as root, or as a user with sudo):
#   bash scripts/demo.sh
# Installs the Debian packages, builds nhnet into build/, estimates normals of the bundled
# noisy sample cloud with PCA, MFPS and NH-Net (the shipped model, models/nhnet.pt), and prints
# where the results are and how accurate
# each method is against the sample's ground-truth normals. Safe to run again (idempotent).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

echo "== 1-2/3 Debian packages, configure and build"
bash scripts/build.sh
CLI=build/cli/nhnet-cli
[[ -x $CLI ]] || { echo "demo: $CLI was not built" >&2; exit 1; }

echo "== 3/3 estimate normals of the bundled sample"
SAMPLE="" GT=""
for f in data/sample/*.xyz; do
  [[ -e $f ]] || continue
  if [[ -f ${f%.xyz}.gt.xyzn ]]; then SAMPLE=$f GT=${f%.xyz}.gt.xyzn; break; fi
done
[[ -n $SAMPLE ]] || { echo "demo: no sample cloud (data/sample/<name>.xyz + <name>.gt.xyzn)" >&2; exit 1; }
name=$(basename "${SAMPLE%.xyz}")
mkdir -p build/demo

echo "input: $SAMPLE ($(grep -c . "$SAMPLE") points, noisy, ground truth in $GT)"
declare -A result
methods=()
for method in pca mfps nhnet; do
  out=build/demo/$name.$method.ply
  if [[ $method == nhnet ]]; then
    # The learned refinement with the shipped model; a build without libtorch says so and the
    # demo goes on with the other two.
    "$CLI" estimate "$SAMPLE" "$out" --method nhnet --overwrite ||
      { echo "demo: nhnet skipped (see the message above)" >&2; continue; }
  else
    "$CLI" estimate "$SAMPLE" "$out" --method "$method" --overwrite
  fi
  result[$method]=$out
  methods+=("$method")
done

echo
echo "Accuracy against the ground truth (unoriented angle error; PGPx = % of points under x deg):"
printf '  %-6s %10s %10s %8s %8s\n' method "mean deg" "RMS deg" PGP5 PGP10
for method in "${methods[@]}"; do
  "$CLI" eval "${result[$method]}" "$GT" | awk -v m="$method" '
    { v[$1] = $2 }
    END { printf "  %-6s %10.2f %10.2f %7.1f%% %7.1f%%\n", m, v["mean"], v["rms"], v["pgp5"], v["pgp10"] }'
done

echo
echo "Results (binary PLY with unit normals nx ny nz; open them in MeshLab or CloudCompare):"
for method in "${methods[@]}"; do echo "  $(pwd)/${result[$method]}"; done
echo "Next: '$CLI estimate --help', or run on your own scan: $CLI estimate scan.ply scan-normals.ply"
