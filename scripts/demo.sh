#!/bin/sh
# Installs what is missing, builds libhetinv (RelWithDebInfo, in build/) and
# runs the main demo, which writes its files to out/demo/.
set -eu
cd "$(dirname "$0")/.."
sh scripts/install-deps.sh demo
cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHETINV_BUILD_TESTS=OFF >/dev/null
cmake --build build -j"$(nproc)"
./build/examples/hetinv-medium-demo out/demo
