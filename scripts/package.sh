#!/usr/bin/env bash
# Builds nhnet's Debian packages into build/packages/ (as root, or with sudo for the packages):
#   bash scripts/package.sh
#   sudo apt install ./build/packages/*.deb
# Installs the build's Debian packages (scripts/install-deps.sh), configures a build of its own in
# build/deb/ for the prefix /usr (the model's path is compiled in; tests, tools and benchmarks
# left out), and runs cpack: nhnet-models, nhnet-cli, python3-nhnet, libnhnet-dev,
# meshlab-plugin-nhnet and cloudcompare-plugin-nhnet (cmake/debian.cmake), each VERSION-1_ARCH.deb.
# A plugin whose host headers are missing is skipped with a warning, never packaged broken.
# Idempotent; tests/package/clean_root.sh installs the result in a fresh Debian 12 root.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

echo "== Debian packages"
bash scripts/install-deps.sh

echo "== configure and build (build/deb/, prefix /usr)"
cmake -S . -B build/deb -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=/usr \
  -DNHNET_DEBIAN_PACKAGES=ON -DNHNET_BUILD_TESTS=OFF -DNHNET_BUILD_TOOLS=OFF \
  -DNHNET_BUILD_BENCH=OFF > build/deb-configure.log ||
  { cat build/deb-configure.log; exit 1; }
grep -E 'SKIPPED' build/deb-configure.log | sed 's/^-- /package: WARNING: /' || true
cmake --build build/deb -j"${NHNET_JOBS:-2}"

echo "== cpack (build/packages/)"
rm -rf build/packages
(cd build/deb && cpack -G DEB -B "$PWD/../packages" > cpack.log) ||
  { cat build/deb/cpack.log; exit 1; }
rm -rf build/packages/_CPack_Packages
for expected in nhnet-models nhnet-cli python3-nhnet libnhnet-dev meshlab-plugin-nhnet \
                cloudcompare-plugin-nhnet; do
  compgen -G "build/packages/${expected}_*.deb" > /dev/null ||
    echo "package: WARNING: no $expected package (its part was not built; see above)"
done
for deb in build/packages/*.deb; do
  printf '%s\n  Depends: %s\n' "$deb" "$(dpkg-deb -f "$deb" Depends)"
done
echo "install: sudo apt install ./build/packages/*.deb"
