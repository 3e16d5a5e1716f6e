#!/usr/bin/env bash
# Installs every Debian 12 package nhnet needs to build, test and benchmark.
# Idempotent: packages already present are left as they are. Needs root (or sudo).
set -euo pipefail

PKGS=(
  # toolchain
  cmake ninja-build g++ pkg-config git
  # formatting (.clang-format; scripts/format.sh, checked in CI)
  clang-format-14
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
  # benchmark: parallel CGAL jet fitting (TBB), its chart (matplotlib), the Open3D venv
  # (bench/setup-open3d.sh makes it with python3-venv)
  libtbb-dev python3-matplotlib python3-venv
  # python side: bindings, data generation, training
  python3-dev python3-numpy pybind11-dev python3-pip
  # nhnet.distributed (python -m nhnet.distributed): Dask distributed, Debian's (2022.12) so that
  # it runs on the same /usr/bin/python3 and numpy the bindings are built for
  python3-distributed
  # reader fuzzing (scripts/fuzz.sh): clang, its libFuzzer/sanitizer runtimes, its OpenMP
  clang libclang-rt-14-dev libomp-14-dev
  # MeshLab plugin: the stock MeshLab, Qt5 and GLEW headers it compiles against, dpkg-dev to
  # unpack MeshLab's source package (its headers), xvfb/xauth to run meshlabserver headless
  meshlab qtbase5-dev libqt5opengl5-dev libglew-dev dpkg-dev xvfb xauth
  # CloudCompare plugin: the stock CloudCompare (its headers: source package, as MeshLab's)
  cloudcompare
  # the plugins' screenshots (docs/plugins.md) (plugins/meshlab/screenshots.sh, scripts/cc-screenshots.sh)
  xdotool imagemagick
  # the plugins' large-cloud tests (label large) measure peak memory with /usr/bin/time -v
  time
  # NH-Net: training (python3-torch) and inference in the core (libtorch-dev, same 1.13)
  python3-torch libtorch-dev
  # their matrix products: Debian's torch calls the libblas.so.3 alternative, which is otherwise
  # the reference BLAS (~16x slower); BLIS, not OpenBLAS, whose load-time buffers hang a
  # process under an address-space limit (docs/design/decisions.md#blis-under-torch)
  libblis4-openmp
  # LAZ and E57 (core/rust: the laz and e57 crates, vendored in core/rust/vendor): Debian 12's own
  # newer Rust toolchain (rustc-web / cargo-web replace /usr/bin/cargo and /usr/bin/rustc; the
  # plain cargo package's 1.63 is too old), never a rustup toolchain that happens to be on PATH
  cargo-web rustc-web
  # Debian packages (scripts/package.sh): nhnet-cli's manual page from its --help
  help2man
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
else
  echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# Plugin headers: the source package of the exact installed version, into deps-src/ (ignored by
# git). Enables deb-src entries derived from this machine's own apt sources when there are none.
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/apt-source.sh meshlab deps-src >/dev/null
bash scripts/apt-source.sh cloudcompare deps-src >/dev/null

# Independent LAS/LAZ/E57 readers and writers for the tests (tests/python/test_formats_las_e57.py,
# tests/cli/bad_input_test.sh): laspy with lazrs, pye57 (wheels), into Debian's python3.
if ! /usr/bin/python3 -c "import laspy, lazrs, pye57" >/dev/null 2>&1; then
  echo "install-deps: installing laspy, lazrs, pye57 (PyPI)"
  $SUDO /usr/bin/python3 -m pip install -q --break-system-packages laspy lazrs pye57
fi
