#!/bin/sh
# Installs the build tree into a scratch prefix, moves the prefix, and starts
# every installed program (--help) with no LD_LIBRARY_PATH: each must find
# the installed libhetinv by itself, wherever the prefix is.
#   usage: programs.sh <build dir> <scratch dir>
set -eu
build=$1
work=$2
rm -rf "$work"
mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix" >"$work/install.log"
mv "$work/prefix" "$work/moved"
found=0
for program in "$work"/moved/bin/*; do
  found=1
  if ! env -u LD_LIBRARY_PATH "$program" --help >"$work/help.log" 2>&1; then
    echo "$(basename "$program") --help failed from the installed prefix:"; cat "$work/help.log"; exit 1
  fi
done
[ "$found" = 1 ] || { echo "no program installed in bin/"; exit 1; }
echo "installed programs start"
