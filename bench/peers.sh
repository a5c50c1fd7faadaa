#!/bin/sh
# hetinv against a peer on the anchor medium A1, in alternating rounds on one
# thread (issue 12: A1 at >= 2.5x MCML 1.2.2 in the same run).
#
#   bench/peers.sh MCML_BINARY [ROUNDS] [PHOTONS] [BUILD_DIR]
#
# MCML_BINARY is MCML 1.2.2 (Wang, Jacques & Zheng), built by the user
# outside this repository (it is not vendored here). A1 for MCML is one slab
# 1 cm thick (mua 10/cm, mus 100/cm, g 0.5, n 1 inside and out), lit by
# MCML's pencil beam at normal incidence; its roulette (1e-4, 0.1) is ours.
# hetinv's A1 is a 10 mm cube of 100^3 voxels (bench/a1_scene.c): laterally
# finite, so Rd agrees to about 1e-3 (0.2950 either way at 10^6 photons).
#
# Each round runs hetinv-bench-forward --case a1 --threads 1 and then MCML on
# the same photon count, and prints both speeds and their ratio; MCML's time
# is its whole process (start-up and writing its .mco are a few ms of the
# seconds it runs). The last line is the median ratio over the rounds.
set -eu
mcml=${1:?usage: bench/peers.sh MCML_BINARY [ROUNDS] [PHOTONS] [BUILD_DIR]}
rounds=${2:-5}
photons=${3:-1000000}
build=${4:-build}
here=$(cd "$(dirname "$0")/.." && pwd)
bench="$here/$build/bench/hetinv-bench-forward"
[ -x "$mcml" ] || { echo "peers.sh: $mcml: not an executable" >&2; exit 2; }
[ -x "$bench" ] || { echo "peers.sh: $bench: not built (cmake --build $build)" >&2; exit 2; }
tmp=$(mktemp -d "${TMPDIR:-/tmp}/hetinv-peers.XXXXXX")
trap 'rm -rf "$tmp"' EXIT INT TERM
cat >"$tmp/a1.mci" <<EOF
1.0                        # file version
1                          # number of runs
a1.mco  A                  # output file
$photons                   # photons
0.01  0.01                 # dz, dr [cm]
100  100  1                # dz, dr, da counts
1                          # layers
1.0                        # n above
1.0   10    100    0.5   1.0
1.0                        # n below
EOF
now() { date +%s.%N; }
ratios=""
i=1
while [ "$i" -le "$rounds" ]; do
  line=$("$bench" --case a1 --threads 1 --photons "$photons" | grep '^a1 ')
  ours=$(echo "$line" | sed -E 's/.*photons_per_s=([0-9.]+).*/\1/')
  (cd "$tmp" && rm -f a1.mco && t0=$(now) && "$mcml" a1.mci >mcml.log 2>&1 && t1=$(now) &&
    echo "$t0 $t1" >times)
  rd=$(awk '/#Diffuse reflectance/ { print $1; exit }' "$tmp/a1.mco")
  peer=$(awk -v n="$photons" '{ printf "%.0f", n / ($2 - $1) }' "$tmp/times")
  ratio=$(awk -v a="$ours" -v b="$peer" 'BEGIN { printf "%.2f", a / b }')
  echo "round $i: hetinv a1 photons_per_s=$ours; mcml photons_per_s=$peer Rd=$rd; hetinv/mcml=$ratio"
  ratios="$ratios $ratio"
  i=$((i + 1))
done
echo "$ratios" | tr ' ' '\n' | grep . | sort -n |
  awk '{ r[NR] = $1 } END { printf "peers a1 rounds=%d median_hetinv_over_mcml=%s min=%s max=%s\n", NR, r[int((NR + 1) / 2)], r[1], r[NR] }'
