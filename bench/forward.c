/* hetinv-bench-forward: forward-render throughput on the anchor medium A1.
 *
 * A1: σa = 1/mm, σs = 10/mm, g = 0.5, a 10 mm cube as 100³ voxels of
 * 0.1 mm, a pencil beam at the centre of the top face (z = z_max) pointing
 * inward, Russian roulette below weight 1e-4 surviving one in ten. Rd is
 * the power leaving through the whole top face (a hemispherical detector).
 *
 * Cases:
 *   a1      η = η_out = 1 (index matched)     reference Rd 0.2950
 *   a1-eta  η = 1.37 in air (η_out = 1)       reference Rd 0.1719, specular 0.0244
 *   a1-het  A1 with σa and σs of every voxel multiplied by independent
 *           factors uniform in [0.5, 1.5] (fixed seed); no reference. It
 *           keeps a homogeneous fast path honest.
 *
 * Every case is rendered with one thread and with two, each from its own
 * context (thread_count 1 and 2, the same seed), so the two renders trace
 * the same photons and must give bitwise-identical values. Output, one
 * line per figure (DESIGN §8):
 *
 *   a1 threads=1 photons=N seconds=T photons_per_s=P Rd=R se=E ref=0.2950 z=Z cpu_seconds=C
 *   a1 threads=2 photons=N ...
 *   a1 scaling_2_over_1=1.93 identical=yes
 *
 * With --repeat R each thread count is run R times, interleaved
 * (2, 1, 2, 1, ...) so that drift of a shared machine hits both alike; the
 * fastest run of each is reported. --threads 1 (or 2) runs one thread
 * count only, for profiling.
 *
 * Where the process may use two CPUs, each round's one-thread render runs
 * twice, pinned to each of them (cores.h: a core's speed drifts by up to
 * 30 % within minutes on the shared machines this runs on, so an unpinned
 * one-thread run measures whichever core it lands on). The scaling line
 * above then takes the fastest of them; a second one sets the two-thread
 * speed against the mean of the two cores' one-thread speeds, the most two
 * threads can reach, for the best runs and each round's:
 *
 *   a1 scaling_2_over_core_mean=1.97 round_min=1.95 round_max=1.99 cpus=0,1 core_seconds=0.85,1.02
 *
 * --het-ratio renders a1 and a1-het on one thread, interleaved (a1,
 * a1-het, a1, ...; --repeat rounds, the fastest of each kept), and prints
 * the speed of the heterogeneous medium relative to the homogeneous one
 * measured in the same process (target of issue 12: >= 0.8):
 *
 *   het_ratio photons=N a1_photons_per_s=P a1_het_photons_per_s=Q het_over_homog=Q/P
 *
 * --passes P makes each measured run P renders back to back (seconds and
 * cpu_seconds are then their total, and ms_per_pass is printed): with few
 * photons per render this is the many-small-passes load of a reconstruction,
 * where the batch loop's synchronisation, not tracing, sets the pace
 * (issue 12: oversubscribed machines). --batches B sets the estimator's
 * batches per emitter (default 64).
 *
 * --write-het-field FILE writes A1-het's voxel field for a peer and exits
 * (nothing is rendered; bench/het_field.h says its layout).
 *
 * This is a benchmark, not a test: it exits non-zero only when the
 * library reports an error.
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "a1_scene.h"
#include "cores.h"
#include "het_field.h"

#define DEFAULT_PHOTONS 1000000.0

static int g_passes = 1;      /* renders per measured run (--passes) */
static double g_batches = 0;  /* estimator batches, 0: the default (--batches) */

/* The outcome of one render. */
typedef struct run {
  double seconds, cpu_seconds, rd, se, specular;
  uint64_t photons;
} run_t;

static bool scene_render(scene_t *s, run_t *out) {
  double rd = 0.0, se = 0.0;
  if (g_batches > 0 &&
      !check(hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_BATCHES, g_batches), s->ctx,
             "set_param BATCHES")) {
    return false;
  }
  double t0 = clock_seconds(CLOCK_MONOTONIC), c0 = clock_seconds(CLOCK_PROCESS_CPUTIME_ID);
  for (int i = 0; i < g_passes; ++i) {
    if (!check(hetinv_estimator_render(s->est, s->medium, s->set, &rd, &se, NULL, 1), s->ctx,
               "render")) {
      return false;
    }
  }
  double t1 = clock_seconds(CLOCK_MONOTONIC), c1 = clock_seconds(CLOCK_PROCESS_CPUTIME_ID);
  hetinv_render_stats_t st = {.size = sizeof st};
  if (!check(hetinv_estimator_get_stats(s->est, &st), s->ctx, "get_stats")) return false;
  *out = (run_t){.seconds = t1 - t0,
                 .cpu_seconds = c1 - c0,
                 .rd = rd,
                 .se = se,
                 .specular = st.specular,
                 .photons = st.photons};
  return true;
}

static void print_run(case_id_t c, int32_t threads, const run_t *r) {
  printf("%s threads=%d photons=%" PRIu64 " seconds=%.3f photons_per_s=%.0f Rd=%.4f se=%.4f",
         cases[c].name, (int)threads, r->photons, r->seconds,
         (double)r->photons * g_passes / r->seconds,
         r->rd, r->se);
  if (cases[c].ref_rd >= 0.0) {
    printf(" ref=%.4f z=%.1f", cases[c].ref_rd,
           r->se > 0.0 ? (r->rd - cases[c].ref_rd) / r->se : 0.0);
  }
  if (cases[c].ref_specular >= 0.0) {
    printf(" specular=%.4f specular_ref=%.4f", r->specular, cases[c].ref_specular);
  }
  /* CPU time of the whole process (all threads, OpenMP spinning included):
   * well below threads × seconds means other work shared the machine. */
  printf(" cpu_seconds=%.3f", r->cpu_seconds);
  if (g_passes > 1) printf(" passes=%d ms_per_pass=%.3f", g_passes, 1e3 * r->seconds / g_passes);
  printf("\n");
}

/* Only one thread count (for profiling): no scaling line. */
static bool bench_case_single(case_id_t c, double photons, int repeat, int32_t threads) {
  scene_t s;
  if (!scene_create(c, threads, photons, &s)) return false;
  run_t best = {.seconds = HUGE_VAL}, r;
  bool ok = true;
  for (int i = 0; ok && i < repeat; ++i) {
    ok = scene_render(&s, &r);
    if (ok && r.seconds < best.seconds) best = r;
  }
  if (ok) print_run(c, threads, &best);
  fflush(stdout);
  scene_destroy(&s);
  return ok;
}

/* One round's one-thread renders: pinned to each of the two CPUs in turn
 * (r[0], r[1]) when the process may use two, else one unpinned (r[0]). */
static bool render_one_thread(scene_t *s, bool pinned, const int cpu[2], run_t r[2]) {
  if (!pinned) return scene_render(s, &r[0]);
  for (int i = 0; i < 2; ++i) {
    bool ok = cores_pin(cpu[i]) && scene_render(s, &r[i]);
    if (!cores_release() || !ok) return false;
  }
  return true;
}

static bool bench_case(case_id_t c, double photons, int repeat) {
  scene_t s1, s2;
  if (!scene_create(c, 1, photons, &s1)) return false;
  if (!scene_create(c, 2, photons, &s2)) {
    scene_destroy(&s1);
    return false;
  }
  int cpu[2];
  const bool pinned = cores_pick(cpu, 2) == 2;
  const int singles = pinned ? 2 : 1;
  run_t best1 = {.seconds = HUGE_VAL}, best2 = {.seconds = HUGE_VAL}, r1[2], r2;
  double best_core[2] = {HUGE_VAL, HUGE_VAL}, round_min = HUGE_VAL, round_max = 0.0;
  bool ok = true, identical = true;
  for (int i = 0; ok && i < repeat; ++i) {
    /* The two-thread render first: the OpenMP pool's thread is made (in
     * the first round) while this thread may still use every CPU, and
     * inherits that set, not a pinned one. */
    ok = scene_render(&s2, &r2) && render_one_thread(&s1, pinned, cpu, r1);
    if (!ok) break;
    if (r2.seconds < best2.seconds) best2 = r2;
    for (int k = 0; k < singles; ++k) {
      if (r1[k].seconds < best1.seconds) best1 = r1[k];
      if (r1[k].seconds < best_core[k]) best_core[k] = r1[k].seconds;
      /* Same seed, same photons: the thread count must not change a bit. */
      if (r1[k].rd != r2.rd || r1[k].se != r2.se || r1[k].rd != best1.rd) identical = false;
    }
    if (pinned) {
      /* This round's two-thread speed over the mean of its cores' speeds. */
      double ratio = 2.0 / r2.seconds / (1.0 / r1[0].seconds + 1.0 / r1[1].seconds);
      if (ratio < round_min) round_min = ratio;
      if (ratio > round_max) round_max = ratio;
    }
  }
  if (ok) {
    print_run(c, 1, &best1);
    print_run(c, 2, &best2);
    printf("%s scaling_2_over_1=%.2f identical=%s\n", cases[c].name, best1.seconds / best2.seconds,
           identical ? "yes" : "NO");
    if (pinned) {
      printf("%s scaling_2_over_core_mean=%.2f round_min=%.2f round_max=%.2f cpus=%d,%d "
             "core_seconds=%.3f,%.3f\n",
             cases[c].name, 2.0 / best2.seconds / (1.0 / best_core[0] + 1.0 / best_core[1]), round_min,
             round_max, cpu[0], cpu[1], best_core[0], best_core[1]);
    }
    fflush(stdout);
  }
  scene_destroy(&s2);
  scene_destroy(&s1);
  return ok;
}

/* a1 and a1-het on one thread, interleaved: the ratio of their speeds. */
static bool bench_het_ratio(double photons, int repeat) {
  scene_t h, x;
  if (!scene_create(CASE_A1, 1, photons, &h)) return false;
  if (!scene_create(CASE_A1_HET, 1, photons, &x)) {
    scene_destroy(&h);
    return false;
  }
  run_t best_h = {.seconds = HUGE_VAL}, best_x = {.seconds = HUGE_VAL}, rh, rx;
  bool ok = true;
  for (int i = 0; ok && i < repeat; ++i) {
    ok = scene_render(&h, &rh) && scene_render(&x, &rx);
    if (!ok) break;
    if (rh.seconds < best_h.seconds) best_h = rh;
    if (rx.seconds < best_x.seconds) best_x = rx;
  }
  if (ok) {
    double ph = (double)best_h.photons / best_h.seconds, px = (double)best_x.photons / best_x.seconds;
    printf("het_ratio photons=%.0f a1_photons_per_s=%.0f a1_het_photons_per_s=%.0f "
           "het_over_homog=%.3f\n",
           photons, ph, px, px / ph);
    fflush(stdout);
  }
  scene_destroy(&x);
  scene_destroy(&h);
  return ok;
}

static void usage(FILE *f) {
  fprintf(f,
          "usage: hetinv-bench-forward [--photons N] [--case a1|a1-eta|a1-het|all] [--repeat R]\n"
          "                            [--threads 1|2] [--het-ratio] [--passes P] [--batches B]\n"
          "       hetinv-bench-forward --write-het-field FILE\n"
          "  --photons N  photons per render (default %.0f)\n"
          "  --case C     which case to run (default all)\n"
          "  --repeat R   renders per thread count; the fastest is reported (default 1)\n"
          "  --threads T  run only with T threads (1 or 2; for profiling: no scaling line)\n"
          "  --het-ratio  a1 and a1-het on one thread, interleaved: speed of a1-het / a1\n"
          "  --passes P   renders per measured run, back to back (default 1)\n"
          "  --batches B  estimator batches per emitter (default: the estimator's, 64)\n"
          "  --write-het-field FILE  write a1-het's sigma_a, sigma_s for mcxyz (doubles, 1/cm,\n"
          "               mcxyz's voxel order; see bench/forward.c) and exit\n",
          DEFAULT_PHOTONS);
}

int main(int argc, char **argv) {
  double photons = DEFAULT_PHOTONS, repeat = 1, only_threads = 0;
  bool het_ratio = false;
  const char *field_path = NULL;
  int first = 0, last = CASE_COUNT - 1;
  for (int i = 1; i < argc; ++i) {
    const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
    if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
      usage(stdout);
      return 0;
    } else if (strcmp(a, "--write-het-field") == 0 && v) {
      if (*v == '\0') {
        fprintf(stderr, "hetinv-bench-forward: --write-het-field wants a file name\n");
        return 2;
      }
      field_path = v;
      ++i;
    } else if (strcmp(a, "--het-ratio") == 0) {
      het_ratio = true;
    } else if (strcmp(a, "--photons") == 0 && v) {
      if (!parse_number(v, 1, 281474976710655.0, &photons)) {
        fprintf(stderr, "hetinv-bench-forward: --photons wants an integer >= 1, not '%s'\n", v);
        return 2;
      }
      ++i;
    } else if (strcmp(a, "--passes") == 0 && v) {
      double p;
      if (!parse_number(v, 1, 1e6, &p)) {
        fprintf(stderr, "hetinv-bench-forward: --passes wants an integer in [1, 1e6], not '%s'\n",
                v);
        return 2;
      }
      g_passes = (int)p;
      ++i;
    } else if (strcmp(a, "--batches") == 0 && v) {
      if (!parse_number(v, 2, 65536, &g_batches)) {
        fprintf(stderr, "hetinv-bench-forward: --batches wants an integer in [2, 65536], not '%s'\n",
                v);
        return 2;
      }
      ++i;
    } else if (strcmp(a, "--repeat") == 0 && v) {
      if (!parse_number(v, 1, 1000, &repeat)) {
        fprintf(stderr, "hetinv-bench-forward: --repeat wants an integer in [1, 1000], not '%s'\n",
                v);
        return 2;
      }
      ++i;
    } else if (strcmp(a, "--threads") == 0 && v) {
      if (!parse_number(v, 1, 2, &only_threads)) {
        fprintf(stderr, "hetinv-bench-forward: --threads wants 1 or 2, not '%s'\n", v);
        return 2;
      }
      ++i;
    } else if (strcmp(a, "--case") == 0 && v) {
      if (strcmp(v, "all") == 0) {
        first = 0;
        last = CASE_COUNT - 1;
      } else {
        int found = find_case(v);
        if (found < 0) {
          fprintf(stderr, "hetinv-bench-forward: unknown case '%s'\n", v);
          usage(stderr);
          return 2;
        }
        first = last = found;
      }
      ++i;
    } else {
      fprintf(stderr, "hetinv-bench-forward: unknown or incomplete option '%s'\n", a);
      usage(stderr);
      return 2;
    }
  }
  if (field_path) return het_field_write(field_path);
  if (het_ratio) return bench_het_ratio(photons, (int)repeat) ? 0 : 1;
  for (int c = first; c <= last; ++c) {
    bool ok = only_threads > 0
                  ? bench_case_single((case_id_t)c, photons, (int)repeat, (int32_t)only_threads)
                  : bench_case((case_id_t)c, photons, (int)repeat);
    if (!ok) return 1;
  }
  return 0;
}
