#!/usr/bin/env bash
# Takes the screenshots (docs/plugins.md#meshlab) of the plugin in the real MeshLab 2020.09 GUI, headless:
#   bash plugins/meshlab/screenshots.sh [build/plugins/meshlab/libfilter_nhnet.so]
# Writes docs/meshlab/menu.png (Filters > Point Set with both filters) and
# docs/meshlab/normals.png (the bundled sample after "Estimate normals (NH-Net)" applied from its
# dialog, normals drawn by Render > Show Normal). MeshLab runs from a private copy whose plugins/
# holds the system plugins plus ours, under Xvfb with no window manager; xdotool clicks at fixed
# positions of the 1280x860 window (valid for Debian's MeshLab 2020.09 with its stock plugins),
# imagemagick's `import` grabs the screen.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
ROOT=$PWD
PLUGIN=$(realpath "${1:-build/plugins/meshlab/libfilter_nhnet.so}")
MLDIR=/usr/lib/x86_64-linux-gnu/meshlab

T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
mkdir -p "$T/ml/plugins" "$T/config" "$T/runtime" docs/meshlab
chmod 700 "$T/runtime"
cp /usr/bin/meshlab "$T/ml/"
for p in "$MLDIR"/plugins/*.so; do ln -s "$p" "$T/ml/plugins/"; done
ln -sf "$PLUGIN" "$T/ml/plugins/"
awk '{ l[n++] = $0 } END { print "ply\nformat ascii 1.0\nelement vertex " n;
       print "property float x\nproperty float y\nproperty float z\nend_header";
       for (i = 0; i < n; i++) print l[i] }' data/sample/fandisk_noise0.6.xyz >"$T/fandisk_noise0.6.ply"

cat >"$T/session.sh" <<'SESSION'
set -euo pipefail
T=$1 ROOT=$2
"$T/ml/meshlab" "$T/fandisk_noise0.6.ply" >"$T/gui.log" 2>&1 &
gui=$!
w=$(xdotool search --sync --name 'MeshLab 2020.09' | head -n1)
xdotool windowmove "$w" 0 0 windowsize "$w" 1280 860
sleep 5
click() { xdotool mousemove "$1" "$2" sleep 0.5 click 1; sleep "${3:-1.5}"; }
click 120 10                        # Filters
click 200 386                       # Point Set
import -window root "$ROOT/docs/meshlab/menu.png"
click 620 461 3                     # Estimate normals (NH-Net): its dialog
# Apply and Close are the dialog's bottom row (its height follows the filter's description).
eval "$(xdotool search --name 'Estimate normals \(NH-Net\)' | head -n1 | xargs xdotool getwindowgeometry --shell)"
click $((X + 450)) $((Y + HEIGHT - 22)) 1   # Apply
# Wait until the filter is done: MeshLab's CPU time stops growing.
prev=-1
for _ in $(seq 300); do
  sleep 2
  now=$(awk '{ print $14 + $15 }' "/proc/$gui/stat")
  [[ $now == "$prev" ]] && break
  prev=$now
done
click $((X + 154)) $((Y + HEIGHT - 22))     # Close the dialog
click 178 10                        # Render
click 222 186 3                     # Show Normal
import -window root "$ROOT/docs/meshlab/normals.png"
kill "$gui"
SESSION

XDG_CONFIG_HOME="$T/config" XDG_RUNTIME_DIR="$T/runtime" LD_LIBRARY_PATH="$MLDIR" \
  xvfb-run -a -s "-screen 0 1280x860x24" bash "$T/session.sh" "$T" "$ROOT"
echo "screenshots: docs/meshlab/menu.png docs/meshlab/normals.png"
