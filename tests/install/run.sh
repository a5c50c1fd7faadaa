#!/bin/sh
# Builds libhetinv without sanitizers, installs it into a temporary prefix,
# then builds and runs tests/install/consumer.c twice: with pkg-config and
# with find_package(hetinv).
#   usage: run.sh <source dir> <scratch dir>
set -eu
src=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
prefix=$work/prefix

cmake -S "$src" -B "$work/build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$prefix" \
  -DHETINV_BUILD_TESTS=OFF -DHETINV_BUILD_EXAMPLES=OFF -DHETINV_BUILD_BENCH=OFF \
  -DHETINV_BUILD_DOCS=OFF >"$work/configure.log"
cmake --build "$work/build" -j2 >"$work/build.log"
cmake --install "$work/build" >"$work/install.log"
libdir=$(cd "$prefix" && ls -d lib* | head -n 1)

echo "== pkg-config"
export PKG_CONFIG_PATH="$prefix/$libdir/pkgconfig"
# shellcheck disable=SC2046 # word splitting of the flags is intended
cc -std=c11 -Wall -Werror -o "$work/consumer-pkgconfig" "$src/tests/install/consumer.c" \
  $(pkg-config --cflags --libs hetinv)
LD_LIBRARY_PATH="$prefix/$libdir" "$work/consumer-pkgconfig"

echo "== find_package"
cmake -S "$src/tests/install" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$prefix" >"$work/consumer.log"
cmake --build "$work/consumer" >>"$work/consumer.log"
LD_LIBRARY_PATH="$prefix/$libdir" "$work/consumer/consumer"

echo "== installed headers"
if find "$prefix/include" -name '*_internal.h' | grep -q .; then
  echo "internal headers were installed"; exit 1
fi
echo "install check passed"
