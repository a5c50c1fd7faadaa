#!/bin/sh
# Builds the peer of bench/peers_mcxyz.sh from the user's own copy of mcxyz.c
# (Jacques' voxel Monte Carlo), outside this repository, which holds only
# the patch (bench/peers_mcxyz.patch says what it changes and for which
# version of mcxyz.c it was made).
#
#   bench/peers_mcxyz_build.sh MCXYZ_C [OUT_DIR]
#
# Copies MCXYZ_C to OUT_DIR/mcxyz.c (default OUT_DIR /tmp/mcxyz-peer), writes
# the patched source to OUT_DIR/mcxyz-hetinv.c and compiles it with
# ${CC:-cc} ${CFLAGS:--O3 -march=native} (the flags of the MCML build that
# bench/peers.sh was measured against) into OUT_DIR/mcxyz-hetinv, whose path
# is the last line printed. MCXYZ_C itself is not changed.
set -eu
usage="usage: bench/peers_mcxyz_build.sh MCXYZ_C [OUT_DIR]"
src=${1:?$usage}
out=${2:-/tmp/mcxyz-peer}
here=$(cd "$(dirname "$0")/.." && pwd)
patchfile="$here/bench/peers_mcxyz.patch"
[ -f "$src" ] || { echo "peers_mcxyz_build.sh: $src: no such file" >&2; exit 2; }
command -v patch >/dev/null || { echo "peers_mcxyz_build.sh: needs patch(1)" >&2; exit 2; }
mkdir -p "$out"
if [ "$(cd "$(dirname "$src")" && pwd)/$(basename "$src")" != "$(cd "$out" && pwd)/mcxyz.c" ]; then
  cp "$src" "$out/mcxyz.c"
fi
if ! patch --dry-run -s -o /dev/null "$out/mcxyz.c" <"$patchfile" >"$out/patch.log" 2>&1; then
  cat "$out/patch.log" >&2
  echo "peers_mcxyz_build.sh: bench/peers_mcxyz.patch does not apply to $src: it was made" \
    "for mcxyz.c of stevjacq/mcxyz2 ('update: nov 11, 2017 slj')" >&2
  exit 1
fi
patch -s -o "$out/mcxyz-hetinv.c" "$out/mcxyz.c" <"$patchfile"
# shellcheck disable=SC2086 # CFLAGS is a list of flags
${CC:-cc} ${CFLAGS:--O3 -march=native} -o "$out/mcxyz-hetinv" "$out/mcxyz-hetinv.c" -lm
echo "$out/mcxyz-hetinv"
