#!/bin/sh
# Builds libhetinv without sanitizers, installs it into a temporary prefix,
# then builds and runs tests/install/consumer.c twice: with pkg-config and
# with find_package(hetinv), and with a C++ compiler consumer.cpp both ways
# too; the build tree is found as a package as well, and every installed
# header compiles alone in C and C++. Further arguments go to the library's
# cmake configuration; with -DHETINV_WITH_MPI=ON it also builds and runs
# consumer_mpi.c (hetinv/mpi.h) both ways.
#   usage: run.sh <source dir> <scratch dir> [cmake options...]
set -eu
src=$1
work=$2
shift 2
rm -rf "$work"
mkdir -p "$work"
prefix=$work/prefix

cmake -S "$src" -B "$work/build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$prefix" \
  -DHETINV_BUILD_TESTS=OFF -DHETINV_BUILD_EXAMPLES=OFF -DHETINV_BUILD_BENCH=OFF \
  -DHETINV_BUILD_DOCS=OFF "$@" >"$work/configure.log"
cmake --build "$work/build" -j2 >"$work/build.log"
cmake --install "$work/build" >"$work/install.log"
libdir=$(cd "$prefix" && ls -d lib* | head -n 1)

echo "== pkg-config"
export PKG_CONFIG_PATH="$prefix/$libdir/pkgconfig"
# shellcheck disable=SC2046 # word splitting of the flags is intended
cc -std=c11 -Wall -Werror -o "$work/consumer-pkgconfig" "$src/tests/install/consumer.c" \
  $(pkg-config --cflags --libs hetinv)
LD_LIBRARY_PATH="$prefix/$libdir" "$work/consumer-pkgconfig"

# hetinv.pc must resolve with no other .pc file: the library links its
# dependencies privately, and a consumer may lack their development packages.
# (A build with MPI requires ompi-c, which hetinv/mpi.h needs.)
if [ ! -f "$prefix/include/hetinv/mpi.h" ]; then
  PKG_CONFIG_LIBDIR="$prefix/$libdir/pkgconfig" pkg-config --exists hetinv ||
    { echo "hetinv.pc needs other packages' .pc files"; exit 1; }
  cflags=$(PKG_CONFIG_LIBDIR="$prefix/$libdir/pkgconfig" pkg-config --cflags hetinv)
  [ "$(echo $cflags)" = "-I$prefix/$libdir/pkgconfig/../../include" ] ||
    { echo "pkg-config --cflags hetinv gives more than its include folder: $cflags"; exit 1; }
fi

if command -v c++ >/dev/null 2>&1; then
  echo "== pkg-config, C++"
  for std in c++17 c++20; do
    # shellcheck disable=SC2046 # word splitting of the flags is intended
    c++ -std=$std -Wall -Wextra -Wpedantic -Werror -o "$work/consumer-cxx-pkgconfig" \
      "$src/tests/install/consumer.cpp" $(pkg-config --cflags --libs hetinv)
    LD_LIBRARY_PATH="$prefix/$libdir" "$work/consumer-cxx-pkgconfig"
  done
fi

echo "== find_package"
cmake -S "$src/tests/install" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$prefix" >"$work/consumer.log"
cmake --build "$work/consumer" >>"$work/consumer.log"
LD_LIBRARY_PATH="$prefix/$libdir" "$work/consumer/consumer"
if [ -x "$work/consumer/consumer_cxx" ]; then
  LD_LIBRARY_PATH="$prefix/$libdir" "$work/consumer/consumer_cxx"
fi

echo "== find_package from the build tree"
cmake -S "$src/tests/install" -B "$work/consumer-build-tree" -Dhetinv_DIR="$work/build" \
  >"$work/consumer-build-tree.log"
cmake --build "$work/consumer-build-tree" >>"$work/consumer-build-tree.log"
"$work/consumer-build-tree/consumer"

echo "== each installed header alone, twice, in C and C++"
for h in "$prefix"/include/hetinv/*.h; do
  name=hetinv/$(basename "$h")
  printf '#include <%s>\n#include <%s>\nint main(void) { return 0; }\n' "$name" "$name" >"$work/header.c"
  # shellcheck disable=SC2046
  cc -std=c11 -Wall -Wextra -Wpedantic -Werror -c -o "$work/header.o" "$work/header.c" $(pkg-config --cflags hetinv) ||
    { echo "$name does not compile alone in C"; exit 1; }
  if command -v c++ >/dev/null 2>&1; then
    # shellcheck disable=SC2046
    c++ -std=c++17 -Wall -Wextra -Wpedantic -Werror -x c++ -c -o "$work/header.o" "$work/header.c" \
      $(pkg-config --cflags hetinv) || { echo "$name does not compile alone in C++"; exit 1; }
  fi
  # Clang checks the Doxygen comments against the declarations (one name per @param).
  if command -v clang >/dev/null 2>&1; then
    # shellcheck disable=SC2046
    clang -std=c11 -Wdocumentation -Werror -fsyntax-only "$work/header.c" $(pkg-config --cflags hetinv) ||
      { echo "$name: its documentation comments do not match its declarations (clang -Wdocumentation)"; exit 1; }
  fi
done

if [ -f "$prefix/include/hetinv/mpi.h" ]; then
  echo "== MPI consumer (pkg-config, find_package)"
  # shellcheck disable=SC2046 # word splitting of the flags is intended
  cc -std=c11 -Wall -Werror -o "$work/consumer-mpi-pkgconfig" "$src/tests/install/consumer_mpi.c" \
    $(pkg-config --cflags --libs hetinv)
  LD_LIBRARY_PATH="$prefix/$libdir" "$work/consumer-mpi-pkgconfig"
  LD_LIBRARY_PATH="$prefix/$libdir" "$work/consumer/consumer_mpi"
  if command -v c++ >/dev/null 2>&1; then
    echo "== MPI consumer from C++ (pkg-config, find_package)"
    # shellcheck disable=SC2046 # word splitting of the flags is intended
    c++ -std=c++17 -Wall -Wextra -Wpedantic -Werror -x c++ -o "$work/consumer-mpi-cxx-pkgconfig" \
      "$src/tests/install/consumer_mpi.c" -x none $(pkg-config --cflags --libs hetinv)
    LD_LIBRARY_PATH="$prefix/$libdir" "$work/consumer-mpi-cxx-pkgconfig"
    LD_LIBRARY_PATH="$prefix/$libdir" "$work/consumer/consumer_mpi_cxx"
    # A C++-only project cannot have MPI::MPI_C: find_package must say how to fix it.
    mkdir -p "$work/cxx-only"
    printf '%s\n' 'cmake_minimum_required(VERSION 3.16)' 'project(cxx_only LANGUAGES CXX)' \
      'find_package(hetinv REQUIRED CONFIG)' >"$work/cxx-only/CMakeLists.txt"
    if cmake -S "$work/cxx-only" -B "$work/cxx-only/build" -DCMAKE_PREFIX_PATH="$prefix" \
      >"$work/cxx-only.log" 2>&1 || ! grep -q 'LANGUAGES C CXX' "$work/cxx-only.log"; then
      echo "find_package(hetinv) in a C++-only project does not say to enable C:"; cat "$work/cxx-only.log"; exit 1
    fi
  fi
fi

echo "== installed headers"
if find "$prefix/include" -name '*_internal.h' | grep -q .; then
  echo "internal headers were installed"; exit 1
fi
# hetinv/mpi.h is installed exactly when the library was built with MPI.
if pkg-config --print-requires hetinv | grep -q ompi-c; then with_mpi=yes; else with_mpi=no; fi
if [ -f "$prefix/include/hetinv/mpi.h" ]; then has_header=yes; else has_header=no; fi
if [ "$with_mpi" != "$has_header" ]; then
  echo "hetinv/mpi.h installed: $has_header, but MPI in hetinv.pc: $with_mpi"; exit 1
fi
echo "install check passed"
