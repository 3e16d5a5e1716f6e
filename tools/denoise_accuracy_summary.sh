#!/usr/bin/env bash
# Per-category summary of a denoise_accuracy output (tools/README.md): for each benchmark
# category (from the model name; the models of datagen's --subset) and normal source, the mean
# distance to the clean surface before / after (% of the bbox diagonal), the mean and worst
# after/before ratio, and the mean and lowest MST sign agreement (all points) and the mean over
# the points within 60 degrees of the truth.
# Usage: bash tools/denoise_accuracy_summary.sh OUTPUT.txt
set -euo pipefail
printf "%-14s %-5s %3s %9s %9s %7s %7s %7s %8s %7s\n" category norm n before_% after_% ratio worst \
  sign_% min_sign sign60
awk 'NR > 1 && $1 != "ran" {
  m = $1; sub(/_noise.*/, "", m)
  cat = (m == "couplingdown" || m == "dragknob") ? "BigNoise" : \
        (m ~ /ChineseDragon|lion-head/) ? "RichFeature" : \
        (m == "fandisk" || m == "rotor") ? "SharpFeature" : "SmoothSurface"
  k = cat " " $2; n[k]++; b[k] += $5; a[k] += $6; r[k] += $7; if ($7 > w[k]) w[k] = $7
  s[k] += $9; s6[k] += $10; if (!(k in lo) || $9 < lo[k]) lo[k] = $9
}
END {
  for (k in n) {
    split(k, f, " ")
    printf "%-14s %-5s %3d %9.4f %9.4f %7.3f %7.3f %7.2f %8.2f %7.2f\n", f[1], f[2], n[k], \
      b[k] / n[k], a[k] / n[k], r[k] / n[k], w[k], s[k] / n[k], lo[k], s6[k] / n[k]
  }
}' "$1" | sort -k1,1 -k2,2
