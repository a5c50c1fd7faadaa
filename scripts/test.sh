#!/bin/sh
# Installs what is missing, then builds and runs the whole test suite:
#  1. every test under AddressSanitizer + UndefinedBehaviorSanitizer, warnings
#     as errors, at -O1 as ASan's documentation advises (build-test/; at -O0
#     this step alone took 540 s of the 15 minutes on a 2-core Xeon, at -O1
#     254 s); Monte Carlo validation tests at reduced size;
#  2. the Monte Carlo validation tests at full size, and the Python binding
#     tests (which cannot load a sanitizer-built library), in an optimised build
#     (build-release/);
#  3. the MPI variant (-DHETINV_WITH_MPI=ON, optimised, build-mpi/): its
#     unit tests and the mpi tests, which run small renders and gradients
#     under mpirun on 1, 2 and 4 ranks and compare them bitwise with each
#     other and with build-release/ (without MPI), give one rank bad input
#     (every rank must fail alike, none hang), and run hetinv-reconstruct on
#     2 ranks; and the installed MPI library's pkg-config file and CMake
#     package;
#  4. the libFuzzer harnesses, built with clang (the library with warnings as
#     errors, so clang's stricter checks hold too), each for a short smoke run
#     (build-fuzz/).
# Ends with one line "hetinv: N passed, M failed".
set -eu
cd "$(dirname "$0")/.."
sh scripts/install-deps.sh test
start=$(date +%s)
jobs=$(nproc)
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
passed=0
failed=0
status=0

# run_suite <build dir> <ctest args...>: runs ctest, adds up its counts.
run_suite() {
  dir=$1
  shift
  log=$dir/ctest.log
  if ctest --test-dir "$dir" --output-on-failure -j"$jobs" "$@" >"$log" 2>&1; then :; else status=1; fi
  cat "$log"
  summary=$(grep -E '[0-9]+ tests failed out of [0-9]+' "$log" | tail -n 1)
  if [ -z "$summary" ]; then
    status=1
    return
  fi
  f=$(echo "$summary" | sed -E 's/.* ([0-9]+) tests failed out of ([0-9]+).*/\1/')
  n=$(echo "$summary" | sed -E 's/.* ([0-9]+) tests failed out of ([0-9]+).*/\2/')
  passed=$((passed + n - f))
  failed=$((failed + f))
}

echo "== sanitizer build (ASan + UBSan, -Werror)"
cmake -S . -B build-test -DCMAKE_BUILD_TYPE=Debug -DCMAKE_C_FLAGS_DEBUG="-g -O1" -DHETINV_SANITIZE=ON \
  -DHETINV_WERROR=ON >/dev/null
cmake --build build-test -j"$jobs"
run_suite build-test

echo "== optimised build: validation at full size, Python binding"
cmake -S . -B build-release -DCMAKE_BUILD_TYPE=Release -DHETINV_WERROR=ON >/dev/null
cmake --build build-release -j"$jobs"
run_suite build-release -L "validation|python"

echo "== MPI build: unit tests and rank-count independence"
cmake -S . -B build-mpi -DCMAKE_BUILD_TYPE=Release -DHETINV_WITH_MPI=ON -DHETINV_WERROR=ON \
  -DHETINV_SERIAL_BUILD_DIR="$PWD/build-release" >/dev/null
cmake --build build-mpi -j"$jobs"
run_suite build-mpi -L "^(mpi|unit|install)$"

echo "== fuzz build (clang, libFuzzer)"
CC=clang cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=Debug -DHETINV_BUILD_FUZZERS=ON \
  -DHETINV_BUILD_TESTS=OFF -DHETINV_BUILD_EXAMPLES=OFF -DHETINV_BUILD_BENCH=OFF \
  -DHETINV_BUILD_DOCS=OFF -DHETINV_WERROR=ON >/dev/null
cmake --build build-fuzz -j"$jobs"
run_suite build-fuzz

echo "test time: $(($(date +%s) - start)) s"
echo "hetinv: $passed passed, $failed failed"
exit $status
