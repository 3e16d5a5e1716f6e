#!/usr/bin/env bash
# Fetches and unpacks the Debian source package of an installed binary package, at exactly the
# installed version (the plugins compile against these headers, so they must match the ABI):
#   scripts/apt-source.sh PACKAGE DESTDIR
# Prints the unpacked tree's path (DESTDIR/<source>-<upstream version>) as the last stdout line.
# Idempotent: an already unpacked tree is reused. Needs root (or sudo) the first time on a machine
# without deb-src entries: it enables them by copying the machine's own apt sources
# (/etc/apt/sources.list.d/*.sources and *.list, /etc/apt/sources.list) with the type changed to
# deb-src, into /etc/apt/sources.list.d/nhnet-deb-src.{sources,list}. No mirror is named here.
set -euo pipefail

if [[ $# != 2 ]]; then
  echo "usage: $0 PACKAGE DESTDIR" >&2
  exit 2
fi
PKG=$1
DEST=$2

SUDO=""
if [[ $(id -u) != 0 ]]; then SUDO="sudo"; fi

version=$(dpkg-query -W -f='${Version}' "$PKG" 2>/dev/null || true)
if [[ -z $version ]]; then
  echo "apt-source: $PKG is not installed; install it first (scripts/install-deps.sh)" >&2
  exit 1
fi
# Source package name and upstream version (no epoch, no Debian revision) name the tree.
src=$(dpkg-query -W -f='${source:Package}' "$PKG")
upstream=${version#*:}
upstream=${upstream%-*}
upstream=${upstream%%+dfsg*}
mkdir -p "$DEST"
DEST=$(cd "$DEST" && pwd)
tree="$DEST/$src-$upstream"
stamp="$tree/.nhnet-apt-source-$version"
if [[ -f $stamp ]]; then
  echo "$tree"
  exit 0
fi

# deb-src entries derived from the existing deb entries, if apt has none yet.
if ! apt-get source --print-uris "$src=$version" >/dev/null 2>&1; then
  echo "apt-source: enabling deb-src entries derived from this machine's apt sources" >&2
  shopt -s nullglob
  out_sources=/etc/apt/sources.list.d/nhnet-deb-src.sources
  out_list=/etc/apt/sources.list.d/nhnet-deb-src.list
  tmp_sources=$(mktemp)
  tmp_list=$(mktemp)
  for f in /etc/apt/sources.list.d/*.sources; do
    [[ $f == "$out_sources" ]] && continue
    # deb822 stanzas: keep those whose Types include deb, rewrite Types to deb-src.
    awk 'BEGIN { RS = ""; ORS = "\n\n" }
         /(^|\n)Types:[^\n]*(^|[ \t])deb([ \t]|\n|$)/ && !/(^|\n)Enabled:[ \t]*no/ {
           sub(/(^|\n)Types:[^\n]*/, "\nTypes: deb-src"); sub(/^\n/, ""); print }' "$f" >>"$tmp_sources"
  done
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    [[ -f $f && $f != "$out_list" ]] || continue
    sed -n 's/^[[:space:]]*deb[[:space:]]\+/deb-src /p' "$f" >>"$tmp_list"
  done
  if [[ -s $tmp_sources ]]; then $SUDO install -m 644 "$tmp_sources" "$out_sources"; fi
  if [[ -s $tmp_list ]]; then $SUDO install -m 644 "$tmp_list" "$out_list"; fi
  rm -f "$tmp_sources" "$tmp_list"
  $SUDO apt-get update -q -o DPkg::Lock::Timeout=900 >&2
fi

# Download into a scratch dir, unpack, move the tree into place (no half-unpacked tree is left).
work=$(mktemp -d "$DEST/.apt-source.XXXXXX")
trap 'rm -rf "$work"' EXIT
(cd "$work" && apt-get source -q --download-only "$src=$version" >&2)
dsc=$(ls "$work"/*.dsc)
(cd "$work" && dpkg-source --no-check -x "$dsc" "$work/tree" >&2)
rm -rf "$tree"
mv "$work/tree" "$tree"
touch "$stamp"
echo "$tree"
