#!/usr/bin/env bash
# The README's first set-up command, as a newcomer meets it: `bash scripts/demo.sh` from a copy of
# the committed tree, as root, in a fresh `debootstrap --variant=minbase bookworm` root, exits 0.
#   bash tests/package/fresh_demo.sh            (as root; from anywhere in the clone)
# Steps:
#   1. a fresh minbase root (tests/package/lib_root.sh: the tarball cached in
#      ~/.cache/nhnet-test-roots/ ($NHNET_ROOT_CACHE), shared with clean_root.sh, made when missing;
#      this machine's apt sources, resolv.conf and local CA certificates (/usr/local/share/
#      ca-certificates: its network's TLS proxy, for pip); /proc, /sys, /dev mounted while used);
#   2. `apt-get install git` in it, and nothing else: a newcomer who cloned the repository has git.
#      apt's indices are then dropped again, so demo.sh has to fetch them itself;
#   3. `git archive HEAD` unpacked as /root/nhnet (FRESH_DEMO_TREE=worktree: HEAD plus the
#      uncommitted changes to tracked files, via `git stash create`, to try a fix before it is
#      committed);
#   4. `cd /root/nhnet && bash scripts/demo.sh` in the root (chroot, a clean environment: no
#      rustup, pyenv, LD_LIBRARY_PATH), every output line time-stamped: the phases (Debian
#      packages, build, demo) are timed from demo.sh's own "== ..." lines;
#   5. checks: demo.sh exited 0; it printed an accuracy line for pca, mfps and nhnet; the build
#      used Debian's /usr/bin/cargo and /usr/bin/rustc (cargo-web / rustc-web) and the root has no
#      rustup and no ~/.cargo.
# apt's downloads are kept in build/fresh-demo/apt-archives (seeded by hard links from
# clean_root.sh's, in the same cache; apt checks every file's hash); FRESH_DEMO_APT_CACHE=0:
# none. KEEP_ROOT=1 keeps the root (unmounted). Logs: build/fresh-demo/last-run/ (demo.log: the
# whole time-stamped output). Prints "fresh-demo: ok ..." lines, the timings and the accuracy lines;
# exits 1 with a one-line reason on failure.
# Needs root (chroot, mount) and network access to the Debian mirror and PyPI (install-deps.sh
# installs laspy, lazrs, pye57 with pip).
set -euo pipefail
# Nothing from /usr/local or ~/.cargo on this machine's side either: the host tools are Debian's.
export PATH=/usr/sbin:/usr/bin:/sbin:/bin LC_ALL=C
unset LD_LIBRARY_PATH PYTHONPATH PYTHONHOME

SELF=$(realpath "${BASH_SOURCE[0]}")
REPO=$(cd "$(dirname "$SELF")/../.." && pwd)
ROOT_TAG=fresh-demo
WORK=$REPO/build/fresh-demo
LOGS=$WORK/last-run
APT_ARCHIVES=""
[[ ${FRESH_DEMO_APT_CACHE:-1} == 1 ]] && APT_ARCHIVES=$WORK/apt-archives
TREE=/root/nhnet            # where the clone is, inside the root
# shellcheck source=tests/package/lib_root.sh
source "$REPO/tests/package/lib_root.sh"
reexec_in_mount_namespace "$SELF" "$@"
cd "$REPO"

# seed_apt_cache: hard links to the .debs clean_root.sh already downloaded (same machine, same
# mirror), so that a run after it downloads only what it lacks. apt re-checks every hash.
seed_apt_cache() {
  local from=$ROOT_CACHE_DIR/apt-archives
  [[ -n $APT_ARCHIVES && -d $from ]] || return 0
  mkdir -p "$APT_ARCHIVES"
  find "$from" -maxdepth 1 -name '*.deb' -exec cp -l -n -t "$APT_ARCHIVES" {} + 2>/dev/null || true
}

# install_git: what a newcomer has before typing the command (the clone needed git); then apt's
# indices go, so that demo.sh (scripts/install-deps.sh) must run apt-get update itself.
install_git() {
  in_root apt-get install -y -q --no-install-recommends git > "$LOGS/git.log" 2>&1 ||
    { tail -n 20 "$LOGS/git.log" >&2; die "apt-get install git in the root failed"; }
  in_root sh -c 'rm -rf /var/lib/apt/lists/* && mkdir -p /var/lib/apt/lists/partial'
  say "git in the root: $(in_root git --version)"
}

# copy_tree: the committed tree (or the working tree's tracked files) as the root's /root/nhnet.
copy_tree() {
  local rev=HEAD
  if [[ ${FRESH_DEMO_TREE:-head} == worktree ]]; then
    rev=$(git -C "$REPO" stash create) || die "git stash create failed"
    [[ -n $rev ]] || rev=HEAD   # nothing uncommitted
  fi
  mkdir -p "$ROOT$TREE"
  git -C "$REPO" archive --format=tar "$rev" | tar -C "$ROOT$TREE" -xf -
  say "tree: git archive $(git -C "$REPO" rev-parse --short "$rev")$([[ $rev != HEAD ]] && echo " (HEAD $(git -C "$REPO" rev-parse --short HEAD) + uncommitted changes)") -> $TREE ($(find "$ROOT$TREE" -type f | wc -l) files)"
}

# run_demo: the README's command, each output line prefixed with the time (seconds since the
# epoch) into demo.log, and shown. Returns demo.sh's exit status.
run_demo() {
  local rc=0
  say "in the root: cd $TREE && bash scripts/demo.sh (log: ${LOGS#"$REPO"/}/demo.log)"
  set +e
  nice -n 10 chroot "$ROOT" /usr/bin/env -i PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    HOME=/root LANG=C.UTF-8 TERM=dumb /bin/bash -c "cd $TREE && bash scripts/demo.sh" 2>&1 < /dev/null |
    while IFS= read -r line; do printf '%s %s\n' "$EPOCHREALTIME" "$line"; done > "$LOGS/demo.log"
  rc=${PIPESTATUS[0]}
  set -e
  echo "$rc" > "$LOGS/demo.rc"
  return "$rc"
}

# phase_timings START: the time from START to demo.sh's first "== ..." line, and between them.
phase_timings() {
  awk -v start="$1" '
    function out(name, a, b) { printf "%s %.1f s\n", name, b - a }
    $2 == "==" && $3 == "Debian" { t_deps = $1 }
    $2 == "==" && $3 == "configure" { t_build = $1 }
    $2 == "==" && $3 == "3/3" { t_demo = $1 }
    { last = $1 }
    END {
      if (t_deps && t_build) out("install-deps", t_deps, t_build)
      if (t_build && t_demo) out("build", t_build, t_demo)
      if (t_demo) out("demo (estimate + eval)", t_demo, last)
      out("demo.sh total", start, last)
    }' "$LOGS/demo.log"
}

# accuracy_lines: demo.sh's accuracy table (header and one line per method).
accuracy_lines() {
  cut -d' ' -f2- "$LOGS/demo.log" | awk '/^Accuracy against/ { on = 1 } on && /^$/ { exit } on { print }'
}

# check_accuracy: a line for each of the three methods, with numbers.
check_accuracy() {
  local m
  for m in pca mfps nhnet; do
    accuracy_lines | grep -qE "^  $m +[0-9.]+ +[0-9.]+ " ||
      die "demo.sh printed no accuracy line for $m$(grep -m1 'nhnet skipped' "$LOGS/demo.log" | cut -d' ' -f2- | sed 's/^/ (/; s/$/)/')"
  done
}

# check_toolchain: the Rust part was built by Debian's cargo and rustc (cargo-web, rustc-web), and
# no rustup toolchain exists in the root.
check_toolchain() {
  local cache=$ROOT$TREE/build/CMakeCache.txt cargo rustc
  [[ -f $cache ]] || die "no $TREE/build/CMakeCache.txt in the root"
  cargo=$(sed -n 's/^NHNET_CARGO:[A-Z]*=//p' "$cache")
  rustc=$(sed -n 's/^NHNET_RUSTC:[A-Z]*=//p' "$cache")
  [[ $cargo == /usr/bin/cargo && $rustc == /usr/bin/rustc ]] ||
    die "the build's cargo/rustc are '$cargo' / '$rustc', not /usr/bin/cargo and /usr/bin/rustc"
  grep -q '/usr/bin/cargo' "$ROOT$TREE/build/build.ninja" ||
    die "build.ninja never calls /usr/bin/cargo"
  in_root sh -c '! command -v rustup && ! test -e /root/.cargo/bin && ! test -e /root/.rustup' > /dev/null ||
    die "the root has a rustup toolchain (rustup, ~/.cargo/bin or ~/.rustup)"
  say "ok toolchain: $cargo ($(in_root dpkg -S "$(in_root readlink -f /usr/bin/cargo)" | cut -d: -f1), $(in_root /usr/bin/cargo --version)), $rustc ($(in_root /usr/bin/rustc --version)); no rustup in the root"
}

main() {
  local t_all t0 rc
  t_all=$(now)
  [[ $(id -u) == 0 ]] || die "needs root (chroot, mount)"
  mkdir -p "$WORK"
  exec 9> "$WORK/.lock"
  flock -n 9 || die "another fresh_demo.sh is running (lock ${WORK#"$REPO"/}/.lock)"
  remove_stale_roots
  rm -rf "$LOGS"
  mkdir -p "$LOGS"
  trap cleanup EXIT
  trap 'exit 130' INT TERM HUP

  seed_apt_cache
  make_root                          # 1. (timed by lib_root.sh)
  t0=$(now); install_git; timing "apt-get install git" "$(since "$t0")"    # 2.
  copy_tree                          # 3.
  t0=$(now)                          # 4.
  rc=0
  run_demo || rc=$?
  while IFS= read -r line; do TIMINGS+=("$line"); done < <(phase_timings "$t0")
  if ((rc != 0)); then
    cut -d' ' -f2- "$LOGS/demo.log" | tail -n 40 >&2
    say "timings: $(printf '%s; ' "${TIMINGS[@]}")"
    die "bash scripts/demo.sh exited $rc in the fresh root (log: ${LOGS#"$REPO"/}/demo.log): $(cut -d' ' -f2- "$LOGS/demo.log" | grep -m1 -E '^E:|error|Error|not found|No such' || cut -d' ' -f2- "$LOGS/demo.log" | tail -n 1)"
  fi
  say "ok bash scripts/demo.sh exited 0"
  check_accuracy                     # 5.
  say "ok accuracy lines for pca, mfps, nhnet:"
  accuracy_lines | sed 's/^/    /'
  check_toolchain
  timing total "$(since "$t_all")"
  say "timings: $(printf '%s; ' "${TIMINGS[@]}")"
  say "passed"
}

main "$@"; exit  # on this line: bash reads a script while it runs it
