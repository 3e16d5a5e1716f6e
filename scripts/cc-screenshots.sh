#!/usr/bin/env bash
# Retakes the CloudCompare screenshots in docs/ (docs/plugins.md#cloudcompare) from the real
# CloudCompare GUI under Xvfb, driven by xdotool at fixed coordinates (CloudCompare 2.11.3's
# layout in a 1280x800 window, no window manager):
#   bash scripts/cc-screenshots.sh [OUTDIR]      (default: docs/)
# Needs the built plugin (build/plugins/cloudcompare/plugins/libQNHNET_PLUGIN.so), Xvfb, xdotool
# and imagemagick (scripts/install-deps.sh). Uses a private XDG_DATA_HOME / XDG_CONFIG_HOME.
# Takes about 3 minutes. Check the pictures: a slow machine may need longer sleeps (SLOW=2).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
ROOT=$PWD
OUT=$(mkdir -p "${1:-docs}" && cd "${1:-docs}" && pwd)
PLUGIN=$ROOT/build/plugins/cloudcompare/plugins/libQNHNET_PLUGIN.so
[[ -f $PLUGIN ]] || { echo "cc-screenshots: build the plugin first ($PLUGIN)" >&2; exit 1; }
SLOW=${SLOW:-1}
pause() { sleep "$(awk -v a="$1" -v s="$SLOW" 'BEGIN { print a * s }')"; }

W=$(mktemp -d "${TMPDIR:-/tmp}/nhnet-cc-shots.XXXXXX")
XVFB_PID="" CC_PID=""
cleanup() {
  [[ -n $CC_PID ]] && kill "$CC_PID" 2>/dev/null || true
  [[ -n $XVFB_PID ]] && kill "$XVFB_PID" 2>/dev/null || true
  rm -rf "$W"
}
trap cleanup EXIT
mkdir -p "$W/data/CCCorp/CloudCompare/plugins" "$W/config"
cp "$PLUGIN" "$W/data/CCCorp/CloudCompare/plugins/"
cd "$W"

# Inputs as PLY (the GUI asks about columns for text files): the noisy sample without normals,
# and the same points with their ground-truth normals (the signs "keep" takes over).
offscreen() {
  XDG_DATA_HOME="$W/data" XDG_CONFIG_HOME="$W/config" XDG_RUNTIME_DIR="$W" QT_QPA_PLATFORM=offscreen \
    CloudCompare -SILENT -NO_TIMESTAMP -AUTO_SAVE OFF -C_EXPORT_FMT PLY "$@" >/dev/null 2>&1
}
cp "$ROOT/data/sample/fandisk_noise0.6.gt.xyzn" gt.xyz
offscreen -O "$ROOT/data/sample/fandisk_noise0.6.xyz" -SAVE_CLOUDS FILE fandisk_noisy.ply
offscreen -O gt.xyz -SAVE_CLOUDS FILE fandisk_scan.ply

DISPLAY_NUM=:$((50 + RANDOM % 40))
Xvfb "$DISPLAY_NUM" -screen 0 1280x800x24 -nolisten tcp >/dev/null 2>&1 &
XVFB_PID=$!
export DISPLAY=$DISPLAY_NUM
pause 2

# start_cc FILE: CloudCompare on FILE, PLY dialog accepted, window 1280x800, cloud selected.
start_cc() {
  XDG_DATA_HOME="$W/data" XDG_CONFIG_HOME="$W/config" XDG_RUNTIME_DIR="$W" CloudCompare "$1" \
    >cc.log 2>&1 &
  CC_PID=$!
  pause 20
  xdotool mousemove 573 682 click 1   # "Apply" in the PLY import dialog
  pause 5
  xdotool windowsize "$(xdotool search --name 'CloudCompare v2' | head -n 1)" 1280 800
  pause 3
  xdotool mousemove 204 119 click 1   # the cloud in the DB tree
  pause 2
}
stop_cc() { kill "$CC_PID"; wait "$CC_PID" 2>/dev/null || true; CC_PID=""; }
# open_action Y: Plugins > NH-Net normals > the entry at height Y (201 estimate, 226 denoise).
open_action() {
  xdotool mousemove 233 10 click 1
  pause 1.5
  xdotool mousemove 280 195; pause 0.3; xdotool mousemove 290 201 click 1
  pause 1.5
  [[ $1 == menu ]] && return 0
  xdotool mousemove 600 201; pause 0.3; xdotool mousemove 610 "$1"; pause 0.3; xdotool click 1
  pause 3
}

start_cc fandisk_noisy.ply
open_action menu
import -window root "$OUT/cloudcompare-menu.png"
xdotool key Escape; pause 0.5; xdotool key Escape; pause 1
open_action 201
import -window root "$OUT/cloudcompare-dialog.png"
xdotool key Escape; pause 1
open_action 226                       # denoise, normals estimated with mfps
xdotool key Return
pause 70
import -window root "$OUT/cloudcompare-denoise.png"
stop_cc

start_cc fandisk_scan.ply
open_action 201                       # estimate, orientation auto = keep the input's signs
xdotool key Return
pause 60
xdotool mousemove 20 585 click 1      # front isometric view
pause 3
xdotool mousemove 345 85; pause 0.3; xdotool mousemove 350 90; pause 1.5
for _ in 1 2 3; do xdotool mousemove 560 86 click 1; pause 1; done   # bigger points
xdotool mousemove 780 400; for _ in 1 2 3; do xdotool click 4; pause 0.5; done   # zoom in
xdotool mousemove 150 250 click 1     # deselect (no bounding box)
pause 2
xdotool mousemove 780 450 mousedown 1
for _ in 1 2 3 4 5 6 7 8; do xdotool mousemove_relative -- -12 -6; pause 0.2; done
xdotool mouseup 1
pause 3
xdotool mousemove 1100 150
pause 2
import -window root "$OUT/cloudcompare-result.png"
stop_cc
echo "cc-screenshots: wrote $OUT/cloudcompare-{menu,dialog,denoise,result}.png"
