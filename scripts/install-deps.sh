#!/bin/sh
# Installs the Debian packages libhetinv needs that are missing (as root, or
# through sudo when available). Safe to run again: installs nothing if all
# are present.
#   usage: install-deps.sh [demo|test]     (test adds the test-only tools)
set -eu
mode=${1:-demo}
pkgs="build-essential cmake pkg-config libopenexr-dev librandom123-dev libpng-dev libcjson-dev"
if [ "$mode" = test ]; then
  # openmpi-*: the MPI build variant (HETINV_WITH_MPI) of scripts/test.sh;
  # python3, python3-numpy, python3-matplotlib: the Python binding's tests (numpy
  # arrays are a tested path) and the Fig. 4(a) figure example; python3-venv,
  # python3-pip, python3-setuptools, python3-wheel: the offline
  # `pip install --no-build-isolation bindings/python` test (python_pip_install);
  # libclang-rt-dev: clang's libFuzzer and sanitizer runtimes for the fuzz
  # build, which clang only recommends (a fresh Debian 12 lacks them)
  pkgs="$pkgs libcmocka-dev doxygen clang libclang-rt-dev libomp-dev binutils openmpi-bin libopenmpi-dev python3 python3-numpy python3-matplotlib"
  pkgs="$pkgs python3-venv python3-pip python3-setuptools python3-wheel"
fi

missing=""
for p in $pkgs; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed"; then
    missing="$missing $p"
  fi
done
[ -z "$missing" ] && exit 0

echo "installing:$missing (apt prints nothing meanwhile; a few minutes on a fresh machine)"
if [ "$(id -u)" -eq 0 ]; then
  sudo=""
elif command -v sudo >/dev/null 2>&1; then
  sudo="sudo"
else
  echo "missing Debian packages:$missing; run this script as root" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
# shellcheck disable=SC2086 # one word per package
$sudo apt-get install -y -qq --no-install-recommends $missing >/dev/null
