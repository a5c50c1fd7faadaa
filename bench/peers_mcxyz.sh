#!/bin/sh
# hetinv against mcxyz on the heterogeneous anchor medium A1-het (and on A1),
# in alternating rounds on one thread (issue 12: public peers beside every
# speed figure, measured in the same run).
#
#   bench/peers_mcxyz.sh MCXYZ_BINARY [ROUNDS] [PHOTONS] [BUILD_DIR]
#
# MCXYZ_BINARY is mcxyz (Jacques' voxel Monte Carlo, mcxyz.c of
# stevjacq/mcxyz2) patched by bench/peers_mcxyz.patch and built outside this
# repository by bench/peers_mcxyz_build.sh MCXYZ_C (unpatched, mcxyz can
# neither take a value per voxel nor run a fixed photon count; the script
# stops if the binary is not the patched one). PEERS_CASES (default
# "a1-het a1") picks the media; each round runs, for each of them,
# hetinv-bench-forward --case C --threads 1 and then mcxyz on the same photon
# count, and prints both speeds, their ratio and both Rd. The end gives per
# medium the median ratio over the rounds, and both Rd with their standard
# errors (hetinv's from its batches: seed 0, the same in every round; mcxyz's
# from the spread of its rounds: it seeds from the clock) and their
# difference in standard errors (z).
#
# The medium, as mcxyz sees it (files under a temporary sims/NAME/, run from
# a sibling directory, as mcxyz2 expects):
#   - 100^3 voxels of 0.01 cm, x' and y' centred on the beam, depth z' from
#     the lit face: mcxyz voxel (ix, iy, iz) is hetinv voxel (ix, iy, 99-iz),
#     a mirror image of hetinv's cube, which transport does not see;
#   - A1-het: the σa and σs of every voxel, exactly as hetinv traces them, in
#     cm^-1 (hetinv-bench-forward --write-het-field: one rounding of ×10);
#     A1: one tissue type, mua 10/cm, mus 100/cm; g 0.5 everywhere;
#   - a pencil beam along +z' from (1e-7, 1e-7, 0) cm, launched inside (no
#     surface reflection: mcxyz has no refractive index, so n = 1 inside and
#     out, which is A1's index-matched boundary). hetinv's beam enters at the
#     corner of four voxel columns and its first flight runs down their
#     common edge in the column that floor() gives, (50, 50); mcxyz's
#     "same voxel?" test (x1 <= xmax, y1 <= ymax) takes a flight that starts
#     exactly on an x or y face and heads into the lower voxel to stay in the
#     upper one, so from the exact corner every photon's second flight is
#     traced with the wrong column's σa and σs, right where the beam enters:
#     Rd 0.3080 against hetinv's 0.3022 on A1-het (z = 14 at 3·10^6 photons;
#     an independent analog tracer gives 0.3019 ± 0.0002). 1e-7 cm (mcxyz's
#     own step past a face) puts the beam inside column (50, 50), hetinv's,
#     and off the faces; on A1 it changes nothing;
#   - escape through every face (boundaryflag 1), Rd = the weight leaving
#     through the lit face (z' <= 0);
#   - roulette below 1e-4, one in ten survives (the patch; mcxyz's is 0.01).
# What differs, and why Rd still agrees within the statistics:
#   - absorption: mcxyz draws flights against σs and takes exp(-σa·s) off the
#     weight along every flight (voxel by voxel); hetinv draws them against
#     σa + σs and multiplies the weight by the albedo at each collision
#     (MCML's scheme). Both are unbiased for Rd; they differ in the variance
#     per photon and in the work per photon (mcxyz has about 10 % fewer
#     interactions, and tests "same voxel?" with floor()s on every flight),
#     so the ratio compares photons of one problem, not equal work per photon;
#   - mcxyz steps 1e-7 cm past each voxel face it crosses and absorbs over
#     that step too (a bias below 1e-5 of a mean free path per crossing);
#   - mcxyz locates voxels with (int), which truncates toward zero: a photon
#     leaving through the x' = -0.5 cm or y' = -0.5 cm face is killed one
#     voxel (0.01 cm) late. 5 mm from the beam, with μeff = 4.2/mm, no
#     weight that matters to Rd gets there;
#   - random numbers: Knuth's subtractive generator at 1e-9 resolution
#     (mcxyz), Philox (hetinv); mcxyz's π is 3.1415926, its dx the float
#     0.01 (0.0099999998 cm). None of these is visible at 10^6 photons.
#     mcxyz seeds from the clock's second, so no two of its runs here start
#     within one second (fewer than ~10^5 photons a run then waits).
# Times: hetinv's is its render (scene set-up excluded), as in
# bench/peers.sh; mcxyz's is its whole process: reading the 16 MB field and
# writing its 4 MB fluence map are tens of ms of the seconds it runs.
set -eu
usage="usage: bench/peers_mcxyz.sh MCXYZ_BINARY [ROUNDS] [PHOTONS] [BUILD_DIR]"
mcxyz=${1:?$usage}
rounds=${2:-5}
photons=${3:-1000000}
build=${4:-build}
cases=${PEERS_CASES:-a1-het a1}
here=$(cd "$(dirname "$0")/.." && pwd)
bench="$here/$build/bench/hetinv-bench-forward"
die() {
  echo "peers_mcxyz.sh: $*" >&2
  exit 2
}
case "$mcxyz" in /*) ;; *) mcxyz="$(pwd)/$mcxyz" ;; esac
[ -x "$mcxyz" ] || die "$mcxyz: not an executable"
[ -x "$bench" ] || die "$bench: not built (cmake --build $build)"
case "$rounds" in '' | *[!0-9]* | 0) die "ROUNDS wants an integer >= 1, not '$rounds'" ;; esac
case "$photons" in '' | *[!0-9]* | 0) die "PHOTONS wants an integer >= 1, not '$photons'" ;; esac
for c in $cases; do
  case "$c" in a1 | a1-het) ;; *) die "PEERS_CASES: '$c' is not a1 or a1-het" ;; esac
done
tmp=$(mktemp -d "${TMPDIR:-/tmp}/hetinv-peers-mcxyz.XXXXXX")
trap 'rm -rf "$tmp"' EXIT INT TERM
mkdir -p "$tmp/run"

# mcxyz's inputs: NAME_H.mci (one value a line, fgets of 31 characters: no
# comments), NAME_T.bin (one tissue-type byte per voxel), NAME_mu.bin.
prepare() { # case name
  d="$tmp/sims/$2"
  mkdir -p "$d"
  # -photons; Nx Ny Nz; dx dy dz [cm]; mcflag launchflag boundaryflag;
  # launch x y z; focus x y z (unused); ux uy uz; radius waist; zsurf;
  # tissue types; mua mus g
  printf '%s\n' "-$photons" 100 100 100 0.01 0.01 0.01 0 1 1 1e-7 1e-7 0 0 0 1e12 0 0 1 0 0 0 \
    1 10 100 0.5 >"$d/$2_H.mci"
  head -c 1000000 /dev/zero | tr '\000' '\001' >"$d/$2_T.bin"
  if [ "$1" = a1-het ]; then
    "$bench" --write-het-field "$d/$2_mu.bin" >"$tmp/field.log" ||
      die "hetinv-bench-forward --write-het-field failed"
  fi
}
name_of() { echo "$1" | tr -d -- -; }
for c in $cases; do prepare "$c" "$(name_of "$c")"; done

now() { date +%s.%N; }
# mcxyz seeds its generator with the clock's second: a run starts only once
# the second in which the previous one ended is over, so no two share a seed.
last_end=0
i=1
while [ "$i" -le "$rounds" ]; do
  for c in $cases; do
    n=$(name_of "$c")
    line=$("$bench" --case "$c" --threads 1 --photons "$photons" | grep "^$c threads=1 ") ||
      die "hetinv-bench-forward --case $c failed"
    ours=$(echo "$line" | sed -E 's/.*photons_per_s=([0-9.]+).*/\1/')
    ours_rd=$(echo "$line" | sed -E 's/.* Rd=([0-9.]+).*/\1/')
    ours_se=$(echo "$line" | sed -E 's/.* se=([0-9.]+).*/\1/')
    rm -f "$tmp/sims/$n/${n}_Rd.dat"
    while [ "$(date +%s)" -le "$last_end" ]; do sleep 0.05; done
    t0=$(now)
    (cd "$tmp/run" && "$mcxyz" "$n" >"$tmp/$n.log" 2>&1) || die "mcxyz $n failed (log: $(tail -n 3 "$tmp/$n.log"))"
    t1=$(now)
    last_end=${t1%.*}
    rd=$(cat "$tmp/sims/$n/${n}_Rd.dat" 2>/dev/null || true)
    echo "$rd" | grep -Eq '^[0-9]+\.[0-9]{6}$' ||
      die "$mcxyz wrote no 6-decimal Rd: not built by bench/peers_mcxyz_build.sh?"
    if [ "$c" = a1-het ] && ! grep -q '^per-voxel mua and mus from' "$tmp/$n.log"; then
      die "$mcxyz did not read the per-voxel field: not built by bench/peers_mcxyz_build.sh?"
    fi
    grep -q "^Nphotons = $(awk -v n="$photons" 'BEGIN { printf "%.2e", n }')\$" "$tmp/$n.log" ||
      die "mcxyz did not run $photons photons"
    peer=$(awk -v n="$photons" -v a="$t0" -v b="$t1" 'BEGIN { printf "%.0f", n / (b - a) }')
    ratio=$(awk -v a="$ours" -v b="$peer" 'BEGIN { printf "%.2f", a / b }')
    echo "round $i: hetinv $c photons_per_s=$ours Rd=$ours_rd; mcxyz photons_per_s=$peer Rd=$rd; hetinv/mcxyz=$ratio"
    echo "$ratio" >>"$tmp/ratios.$c"
    echo "$rd" >>"$tmp/rd.$c"
    echo "$ours_rd $ours_se" >"$tmp/ours.$c"
  done
  i=$((i + 1))
done
for c in $cases; do
  sort -n "$tmp/ratios.$c" | awk -v c="$c" '{ r[NR] = $1 }
    END { printf "peers_mcxyz %s rounds=%d median_hetinv_over_mcxyz=%s min=%s max=%s\n", c, NR, r[int((NR + 1) / 2)], r[1], r[NR] }'
  read -r ours_rd ours_se <"$tmp/ours.$c"
  awk -v c="$c" -v h="$ours_rd" -v hs="$ours_se" '{ s += $1; q += $1 * $1; n++ }
    END {
      m = s / n
      se = n > 1 ? sqrt((q - n * m * m) / (n - 1) / n) : 0
      d = m - h
      z = sqrt(hs * hs + se * se)
      printf "peers_mcxyz %s Rd hetinv=%.4f se=%.4f mcxyz=%.4f se=%.4f (%d runs) mcxyz_minus_hetinv=%.4f z=%s\n",
        c, h, hs, m, se, n, d, (z > 0 ? sprintf("%.1f", d / z) : "n/a")
    }' "$tmp/rd.$c"
done
