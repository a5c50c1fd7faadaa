/* hetinv-efficient-check: test helper for recon_bound_efficient
 * (efficient.c). Draws many efficient recoveries of a made-up bound map
 * (each voxel's relative error normal with its bound as standard
 * deviation, independent) and compares, within 4 standard errors of the
 * draw, the counted voxels over the target with over_max and the share of
 * draws with none over it with pass. Then the edge cases: an infinite
 * bound misses surely, a NaN one is left out, a zero one never misses.
 * Exit 0 when all hold, 1 naming the first that fails. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "recon.h"

#define VOXELS 12
#define DRAWS 200000

static uint64_t state = 0x9e3779b97f4a7c15u;

static double uniform(void) { /* splitmix64, 53 bits, in (0, 1) */
  uint64_t z = (state += 0x9e3779b97f4a7c15u);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9u;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebu;
  z ^= z >> 31;
  return ((double)(z >> 11) + 0.5) / 9007199254740992.0;
}

static double normal(void) { /* Box–Muller, one of the pair */
  return sqrt(-2.0 * log(uniform())) * cos(6.283185307179586 * uniform());
}

static int check(const char *what, double got, double want, double se) {
  int ok = fabs(got - want) <= 4.0 * se;
  printf("%s: %.5f, drawn %.5f +- %.5f: %s\n", what, got, want, se, ok ? "ok" : "FAILED");
  return ok ? 0 : 1;
}

int main(void) {
  static double rel[3][VOXELS];
  const double max_rel = 0.15;
  for (int p = 0; p < 3; ++p) {
    for (int v = 0; v < VOXELS; ++v) rel[p][v] = 0.02 + 0.01 * (double)((v * 7 + p * 3) % 9); /* 2 to 10 % */
  }
  recon_bound_t b;
  memset(&b, 0, sizeof b);
  b.done = true;
  for (int p = 0; p < 3; ++p) b.rel[p] = rel[p];
  recon_efficient_t eff;
  recon_bound_efficient(&b, VOXELS, max_rel, &eff);

  double count[3] = {0}, count_sq[3] = {0}, passes = 0.0;
  for (int i = 0; i < DRAWS; ++i) {
    int all = 1;
    for (int p = 0; p < 3; ++p) {
      int over = 0;
      for (int v = 0; v < VOXELS; ++v) over += fabs(normal() * rel[p][v]) > max_rel;
      count[p] += over;
      count_sq[p] += (double)over * over;
      all &= over == 0;
    }
    passes += all;
  }
  int failed = 0;
  const char *names[3] = {"sigma_a voxels over the target", "sigma_s voxels over the target",
                          "g voxels over the target"};
  for (int p = 0; p < 3; ++p) {
    double mean = count[p] / DRAWS, var = count_sq[p] / DRAWS - mean * mean;
    failed |= check(names[p], eff.over_max[p], mean, sqrt(var / DRAWS));
  }
  double share = passes / DRAWS;
  failed |= check("pass probability", eff.pass, share, sqrt(share * (1.0 - share) / DRAWS));

  double old_miss[3];
  for (int p = 0; p < 3; ++p) old_miss[p] = erfc(max_rel / rel[p][0] / sqrt(2.0));
  rel[0][0] = HUGE_VAL; /* undetermined: misses surely */
  rel[1][0] = (double)NAN; /* no bound: left out */
  rel[2][0] = 0.0;      /* determined exactly: never misses */
  recon_efficient_t edge;
  recon_bound_efficient(&b, VOXELS, max_rel, &edge);
  const double want[3] = {eff.over_max[0] - old_miss[0] + 1.0, eff.over_max[1] - old_miss[1],
                          eff.over_max[2] - old_miss[2]};
  int edges = edge.pass == 0.0;
  for (int p = 0; p < 3; ++p) edges &= fabs(edge.over_max[p] - want[p]) <= 1e-12;
  printf("an infinite bound (sigma_a): over %.6f, want %.6f, pass %g; a NaN one (sigma_s): over %.6f, want %.6f; "
         "a zero one (g): over %.6f, want %.6f: %s\n",
         edge.over_max[0], want[0], edge.pass, edge.over_max[1], want[1], edge.over_max[2], want[2],
         edges ? "ok" : "FAILED");
  failed |= !edges;

  recon_bound_t none;
  memset(&none, 0, sizeof none);
  recon_efficient_t nan_eff;
  recon_bound_efficient(&none, VOXELS, max_rel, &nan_eff);
  int nans = isnan(nan_eff.pass) && isnan(nan_eff.over_max[0]);
  printf("no bound: NaN: %s\n", nans ? "ok" : "FAILED");
  failed |= !nans;
  return failed ? 1 : 0;
}
