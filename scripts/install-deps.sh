#!/usr/bin/env bash
# Installs every Debian 12 package nhnet needs to build, test and benchmark.
# Idempotent: packages already present are left as they are. Needs root (or sudo).
set -euo pipefail

PKGS=(
  # toolchain
  cmake ninja-build g++ pkg-config git
  # core: linear algebra, kd-tree, parallel loops come with g++ (OpenMP)
  libeigen3-dev libnanoflann-dev
  # cli
  libcli11-dev
  # tests
  libgtest-dev libgmock-dev python3-pytest
  # PCL (PCA peer in the benchmark, PCL-style adapter) and CGAL (orientation, jet/VCM peers)
  libpcl-dev libcgal-dev
  # meshes the benchmark and training data are sampled from
  libcgal-demo
  # python side: bindings, data generation, training
  python3-dev python3-numpy pybind11-dev
  # reader fuzzing (scripts/fuzz.sh): clang, its libFuzzer/sanitizer runtimes, its OpenMP
  clang libclang-rt-14-dev libomp-14-dev
)

SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi

missing=()
for p in "${PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ "${#missing[@]}" -eq 0 ]; then
  echo "install-deps: all ${#PKGS[@]} packages already installed"
  exit 0
fi

echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
