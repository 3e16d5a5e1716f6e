# shellcheck shell=bash
# Shared helpers for the tests that run in a fresh `debootstrap --variant=minbase bookworm` root
# (tests/package/clean_root.sh, tests/package/fresh_demo.sh). Source it; it runs nothing by
# itself.
#
# The caller sets, before calling make_root:
#   ROOT_TAG   prefix of every message ("fresh-demo")
#   REPO       the repository root (absolute)
#   WORK       a directory of the caller's own (absolute): temp roots root.*, debootstrap.*
#   LOGS       where logs go (absolute, exists)
#   CACHE      the minbase tarball (default $ROOT_CACHE_DIR/bookworm-minbase.tar; made when
#              missing, ROOT_REFRESH=1 makes it again)
#   APT_ARCHIVES  a directory bind-mounted on the root's /var/cache/apt/archives, so that apt's
#              downloads are kept between runs (apt checks each file's hash against the fresh
#              indices, so the root still gets what a user's would); empty: none
#   ROOT_IMAGE 1: the root is a file system of its own in a sparse image ($ROOT.img), which goes
#              with one unmount and one rm instead of ~130 000 unlinks (minutes); 0: a directory
# ROOT_CACHE_DIR (default: NHNET_ROOT_CACHE, else ~/.cache/nhnet-test-roots) holds what is kept
# between runs, outside the clone, as pip's and apt's caches are: a fresh clone (CI) reuses it.
# and gets ROOT (the temp root, absolute) and MOUNTS. cleanup is meant for `trap cleanup EXIT`.
# Needs root (debootstrap, chroot, mount). No mirror is named here: the root gets this machine's
# own apt sources.

SUITE=${SUITE:-bookworm}
ROOT_CACHE_DIR=${NHNET_ROOT_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/nhnet-test-roots}
CACHE=${CACHE:-$ROOT_CACHE_DIR/bookworm-minbase.tar}
APT_ARCHIVES=${APT_ARCHIVES:-}
ROOT_IMAGE=${ROOT_IMAGE:-0}
ROOT=""        # the temp root (absolute), once made
MOUNTS=()      # what is mounted under it, in mount order
TIMINGS=()

say() { echo "$ROOT_TAG: $*"; }
# die REASON: a failure nothing after it can run without (the one-line reason, then exit 1).
die() { echo "$ROOT_TAG: FAIL: $*" >&2; exit 1; }
now() { echo "$EPOCHREALTIME"; }
since() { awk -v a="$1" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.1f", b - a }'; }
timing() { TIMINGS+=("$1 $2 s"); }

# reexec_in_mount_namespace "$0" "$@": re-runs the calling script in a private mount namespace
# when possible (then no mount can outlive it, even if it is killed; cleanup unmounts anyway).
reexec_in_mount_namespace() {
  local self=$1; shift
  if [[ -z ${LIB_ROOT_NS:-} ]] && unshare --mount --propagation private true 2>/dev/null; then
    exec unshare --mount --propagation private env LIB_ROOT_NS=1 bash "$self" "$@"
  fi
}

# mirror_uri: the URI of the first `deb` entry of the main $SUITE suite in this machine's apt
# sources, in apt's order (sources.list, then sources.list.d/*.list and *.sources alphabetically).
mirror_uri() {
  local f uri
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*; do
    [[ -f $f ]] || continue
    case $f in
      *.list)
        # deb [opt=val ...] URI SUITE COMPONENT...
        uri=$(awk -v suite="$SUITE" '$1 == "deb" { i = 2
                if ($i ~ /^\[/) { while (i <= NF && $i !~ /\]$/) i++; i++ }
                if ($(i + 1) == suite) { print $i; exit } }' "$f") ;;
      *.sources)
        # deb822 stanzas: Types: deb ..., URIs: ..., Suites: ... bookworm ...
        uri=$(awk -v suite="$SUITE" 'BEGIN { RS = ""; FS = "\n" }
              { types = uris = suites = ""; enabled = "yes"
                for (j = 1; j <= NF; j++) {
                  if ($j ~ /^[ \t]*#/ || $j !~ /:/) continue
                  key = tolower(substr($j, 1, index($j, ":") - 1)); val = substr($j, index($j, ":") + 1)
                  if (key == "types") types = " " val " "; else if (key == "uris") uris = val
                  else if (key == "suites") suites = " " val " "; else if (key == "enabled") enabled = val }
                gsub(/[ \t]+/, " ", types); gsub(/[ \t]+/, " ", suites); gsub(/[ \t]/, "", enabled)
                if (types ~ / deb / && suites ~ (" " suite " ") && tolower(enabled) != "no") {
                  n = split(uris, u, " "); for (k = 1; k <= n; k++) if (u[k] != "") { print u[k]; exit } } }' "$f") ;;
      *) continue ;;
    esac
    if [[ -n $uri ]]; then echo "$uri"; return 0; fi
  done
  return 1
}

# ensure_host_tool COMMAND PACKAGE: apt-get install PACKAGE on this machine when COMMAND is missing.
ensure_host_tool() {
  command -v "$1" > /dev/null && return 0
  say "installing $2 on this machine"
  { DEBIAN_FRONTEND=noninteractive apt-get install -y -q "$2" ||
    { apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q "$2"; }; } \
    > "$LOGS/host-apt-$2.log" 2>&1 ||
    { tail -n 20 "$LOGS/host-apt-$2.log" >&2; die "apt-get install $2 on this machine failed"; }
}

# make_cache: debootstrap --variant=minbase $SUITE into a temp dir, tarred as $CACHE (renamed into
# place whole, so a concurrent reader never sees half a tarball).
make_cache() {
  local mirror tmp t0
  mirror=$(mirror_uri) || die "no 'deb' entry for $SUITE in /etc/apt/sources.list{,.d} (the mirror to debootstrap from)"
  ensure_host_tool debootstrap debootstrap
  mkdir -p "$(dirname "$CACHE")"
  tmp=$(mktemp -d "$WORK/debootstrap.XXXXXX")
  say "debootstrap --variant=minbase $SUITE from $mirror (cached in ${CACHE#"$REPO"/})"
  t0=$(now)
  debootstrap --variant=minbase "$SUITE" "$tmp/root" "$mirror" > "$LOGS/debootstrap.log" 2>&1 ||
    { tail -n 20 "$LOGS/debootstrap.log" >&2; rm -rf --one-file-system "$tmp"; die "debootstrap failed (log: ${LOGS#"$REPO"/}/debootstrap.log)"; }
  tar --numeric-owner -C "$tmp/root" -cpf "$tmp/cache.tar" .
  mv "$tmp/cache.tar" "$CACHE.tmp.$$" && mv "$CACHE.tmp.$$" "$CACHE"
  rm -rf --one-file-system "$tmp"
  timing debootstrap "$(since "$t0")"
}

# mounted_under DIR: the mount points at or under DIR (from this process's mount table).
mounted_under() {
  awk -v d="$1" '{ gsub(/\\040/, " ", $5) } $5 == d || index($5, d "/") == 1 { print $5 }' /proc/self/mountinfo
}

# remove_stale_roots: root.* and debootstrap.* under $WORK that a killed run left (never mounted:
# its mounts died with its mount namespace). Call it only while holding the caller's lock.
remove_stale_roots() {
  local p
  for p in "$WORK"/root.* "$WORK"/debootstrap.*; do
    if [[ -e $p && -z $(mounted_under "${p%.img}") ]]; then rm -rf --one-file-system "$p"; fi
  done
}

# mnt DIR MOUNT-ARGS...: mount on the root's DIR, remembered for the clean-up.
mnt() {
  local dir=$ROOT$1; shift
  mount "$@" "$dir" || die "cannot mount $* on $dir"
  MOUNTS+=("$dir")
}

# mount_root: /proc, /sys, /dev (bind, with /dev/pts) and a /dev/shm of its own for the root, and
# $APT_ARCHIVES on its apt cache.
mount_root() {
  mnt /proc -t proc proc
  mnt /sys --bind /sys
  mnt /dev --bind /dev
  # private: a mount under the root's /dev must never show up in the host's /dev
  mount --make-private "$ROOT/dev"
  mnt /dev/pts --bind /dev/pts
  mnt /dev/shm -t tmpfs -o mode=1777,size=1g shm
  if [[ -n $APT_ARCHIVES ]]; then
    mkdir -p "$APT_ARCHIVES"
    mnt /var/cache/apt/archives --bind "$APT_ARCHIVES"
  fi
}

# cleanup (EXIT trap): stop what still runs in the root, unmount, remove the root (KEEP_ROOT=1:
# keep it, unmounted).
# shellcheck disable=SC2317  # called by the caller's EXIT trap
cleanup() {
  local rc=$? p i m
  [[ -n $ROOT ]] || return "$rc"
  # processes whose root directory is ours (an Xvfb or dbus left behind), by their id
  for p in /proc/[0-9]*; do
    if [[ $(readlink "$p/root" 2>/dev/null) == "$ROOT" ]]; then kill -TERM "${p#/proc/}" 2>/dev/null || true; fi
  done
  for ((i = ${#MOUNTS[@]} - 1; i >= 0; i--)); do
    m=${MOUNTS[i]}
    umount "$m" 2>/dev/null || { sleep 1; umount "$m" 2>/dev/null; } || umount -l "$m" ||
      echo "$ROOT_TAG: WARNING: could not unmount $m" >&2
  done
  if [[ -n $(mounted_under "$ROOT") ]]; then
    echo "$ROOT_TAG: WARNING: still mounted, $ROOT left in place: $(mounted_under "$ROOT" | tr '\n' ' ')" >&2
  elif [[ ${KEEP_ROOT:-0} == 1 && -f $ROOT.img ]]; then
    echo "$ROOT_TAG: root kept in $ROOT.img (mount -o loop $ROOT.img $ROOT to look)" >&2
  elif [[ ${KEEP_ROOT:-0} == 1 ]]; then
    echo "$ROOT_TAG: root kept (unmounted) in $ROOT" >&2
  else
    local t0
    t0=$(now)
    rm -rf --one-file-system "$ROOT" "$ROOT.img"
    say "removed the root ($(since "$t0") s)"
  fi
  return "$rc"
}

# in_root CMD ARGS...: CMD in the root, with a clean environment (no LD_LIBRARY_PATH, no
# PYTHONPATH, no rustup or pyenv: what a root login shell on a fresh machine has).
in_root() {
  chroot "$ROOT" /usr/bin/env -i PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    HOME=/root LANG=C.UTF-8 TERM=dumb DEBIAN_FRONTEND=noninteractive "$@"
}

# copy_apt_sources: this machine's apt sources into the root (deb entries only: the root needs no
# source indices), and the keyrings they name that the root lacks.
copy_apt_sources() {
  local f dst key
  rm -f "$ROOT/etc/apt/sources.list" "$ROOT"/etc/apt/sources.list.d/*
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*; do
    [[ -f $f ]] || continue
    case $f in
      *.list) dst=$ROOT/etc/apt/${f#/etc/apt/}
              grep -Ev '^[[:space:]]*deb-src[[:space:]]' "$f" > "$dst" || true ;;
      *.sources) dst=$ROOT/etc/apt/${f#/etc/apt/}
                 # stanzas with Types: deb, as Types: deb only
                 awk 'BEGIN { RS = ""; ORS = "\n\n" }
                      { n = split($0, line, "\n"); keep = 1; out = ""
                        for (i = 1; i <= n; i++) {
                          if (line[i] ~ /^[Tt]ypes:/) {
                            if (substr(line[i], 7) !~ /(^|[ \t])deb([ \t]|$)/) keep = 0
                            line[i] = "Types: deb" }
                          out = out (i > 1 ? "\n" : "") line[i] }
                        if (keep) print out }' "$f" > "$dst" ;;
      *) continue ;;
    esac
    # a file of deb-src entries only is left out
    grep -qvE '^[[:space:]]*(#|$)' "$dst" || rm -f "$dst"
  done
  # Signed-By / signed-by= keyring files
  while IFS= read -r key; do
    if [[ -f $key && ! -e $ROOT$key ]]; then
      mkdir -p "$(dirname "$ROOT$key")"
      cp "$key" "$ROOT$key"
    fi
  done < <(cat "$ROOT"/etc/apt/sources.list "$ROOT"/etc/apt/sources.list.d/* 2>/dev/null |
           grep -oiE '(signed-by[=:][[:space:]]*)/[^] ,]+' | sed -E 's/^[^/]*//' | sort -u)
}

# copy_local_ca_certs: the certificate authorities this machine adds to Debian's
# (/usr/local/share/ca-certificates/*.crt: a network's TLS proxy, a company CA) into the root's
# same directory, as resolv.conf is copied: part of the network, not of what is tested. Nothing is
# installed: they count once ca-certificates is installed in the root (its postinst runs
# update-ca-certificates, which reads that directory).
copy_local_ca_certs() {
  local d=/usr/local/share/ca-certificates
  [[ -d $d ]] || return 0
  mkdir -p "$ROOT$d"
  find "$d" -maxdepth 2 -name '*.crt' -type f -exec cp -t "$ROOT$d" {} +
}

# make_root: a fresh root from the cache (made first when missing), mounted, with apt's indices.
make_root() {
  local t0
  t0=$(now)
  if [[ ! -f $CACHE || ${ROOT_REFRESH:-0} == 1 ]]; then make_cache; fi
  ROOT=$(mktemp -d "$WORK/root.XXXXXX")
  if [[ $ROOT_IMAGE == 1 ]]; then
    if truncate -s 24G "$ROOT.img" && mkfs.ext4 -q -F -O ^has_journal -E nodiscard "$ROOT.img" &&
       mount -o loop "$ROOT.img" "$ROOT"; then
      MOUNTS+=("$ROOT")
    else
      say "WARNING: no loop-mounted image (see above), the root is a plain directory"
      rm -f "$ROOT.img"
    fi
  fi
  chmod 755 "$ROOT"   # the root's / (apt's _apt user must traverse it)
  tar --numeric-owner -C "$ROOT" -xpf "$CACHE"
  cp -L /etc/resolv.conf "$ROOT/etc/resolv.conf"
  copy_local_ca_certs
  copy_apt_sources
  # No service starts inside the chroot (as piuparts does), and dpkg does not fsync each of the
  # ~100 000 files it unpacks (the root is thrown away; what gets installed is the same).
  printf '#!/bin/sh\nexit 101\n' > "$ROOT/usr/sbin/policy-rc.d"
  chmod 755 "$ROOT/usr/sbin/policy-rc.d"
  echo force-unsafe-io > "$ROOT/etc/dpkg/dpkg.cfg.d/lib-root-unsafe-io"
  mount_root
  timing "root from ${CACHE#"$REPO"/}" "$(since "$t0")"
  say "root $ROOT (from ${CACHE#"$REPO"/}); apt sources: $(cd "$ROOT/etc/apt" && find sources.list sources.list.d -maxdepth 1 -type f 2>/dev/null | sort | tr '\n' ' ')"
  t0=$(now)
  in_root apt-get update -q > "$LOGS/apt-update.log" 2>&1 ||
    { tail -n 20 "$LOGS/apt-update.log" >&2; die "apt-get update in the root failed"; }
  grep -E '^(W|E):' "$LOGS/apt-update.log" >&2 || true   # warnings: shown, not fatal
  timing "apt-get update" "$(since "$t0")"
}
