/* hetinv-bench-reconstruct: the built-in reduced Fig. 4 scene of
 * hetinv-reconstruct (recon_scene_builtin: a 6 × 1 × 6 section of a 0.6 mm cube, η = 1.3,
 * steady-state cameras on four faces), end to end: ground truth, simulated
 * acquisition, the coarse-to-fine optimisation, errors and output files.
 *
 *   hetinv-bench-reconstruct [--iterations N] [--photons N] [--truth-photons N]
 *                            [--threads N] [-o DIR] [--require MEAN,MAX] [--seeds A-B]
 *                            [--scene FILE] [--bound-photons N [--bound-only]]
 *
 * --iterations: of the finest stage (default the scene's, 600); coarser
 * stages get the scene's fraction of it, as in hetinv-reconstruct.
 * --photons: photons per emitter of the optimiser's estimator (default the
 * scene's). --truth-photons: photons per emitter of the simulated
 * measurements (default the scene's, 30000; the smoke test lowers it, since
 * the simulation of 96 sources dominates a short run).
 * --threads: 0 = all cores (default the scene's). Without -o the outputs go
 * to a temporary directory that is removed at the end.
 * --scene FILE: a hetinv-reconstruct scene read over the built-in one
 * before the other options (e.g. {"acquisition": {"weighting": "relative"}}
 * to measure a variant on every volume); --seeds still sets the truth and
 * noise seeds of each volume.
 * --bound-photons N: also the Cramér–Rao bound of each volume at its truth
 * (8 replicates of N photons per emitter; hetinv-reconstruct's bound), and
 * per parameter the largest voxel error ÷ that voxel's bound and how many
 * voxels miss by more than twice their bound (an efficient unbiased
 * recovery: about 4.6 % of them by chance):
 *
 *   reconstruct param=g mean_rel_bound=… max_error_over_bound=… voxels_over_2x_bound=N/M
 *
 * and the summary line gains g_max_error_over_bound=… (likewise σa, σs).
 * With --require as well, what an efficient unbiased recovery would score
 * (recon_bound_efficient): per parameter the expected number of voxels
 * over the max target, "efficient_voxels_over_max=…", and per volume a
 * lower and an upper bound of its odds of passing the max target,
 * "efficient_pass_at_least=… efficient_pass_at_most=…", summed over the
 * volumes into the last line's "efficient_expected_passes_at_least=…
 * efficient_expected_passes_at_most=…": the pass count the data allow,
 * against which the batch's own count is read.
 * --bound-only: the bound without the reconstruction (with -o, bound.exr
 * and its PNGs per volume): per volume its bound lines, then
 *
 *   reconstruct seed=s seconds=T efficient_pass_at_least=P efficient_pass_at_most=Q
 *
 * and "reconstruct volumes=N passed=- efficient_expected_passes_at_least=E …":
 * whether a scene's data can meet the target on most volumes, before
 * any volume is reconstructed.
 *
 * Output, one line per figure (DESIGN §8):
 *
 *   reconstruct scene="reduced Fig. 4" grid=6x1x6 sources=S rows=R threads=T photons=P truth_photons=Q iterations=I iterations_all_stages=A
 *   reconstruct simulate_seconds=…
 *   reconstruct optimisation_seconds=…
 *   reconstruct total_seconds=…
 *   reconstruct seconds_per_iteration=…   (optimisation seconds / iterations of all stages)
 *   reconstruct param=sigma_a mean_rel_error=… max_rel_error=…   (and sigma_s, g)
 *
 * --require MEAN,MAX (e.g. 0.07,0.15, the paper's figures): exit 3 when
 * any parameter's mean or max relative error is above them, naming it;
 * the test reconstruct_accuracy runs the default scene so. Otherwise a
 * benchmark: it exits non-zero only on a library error (1) or a usage
 * error (2).
 *
 * --seeds A-B: the same scene on the truth volumes A..B, volume s with
 * truth seed s and noise seed s (the built-in volume is seed 1), so that an
 * accuracy figure is not one lucky volume. Each volume prints its lines
 * prefixed "reconstruct seed=s", then one summary line
 *
 *   reconstruct seed=s sigma_a=MEAN/MAX sigma_s=MEAN/MAX g=MEAN/MAX seconds=T pass=yes|no|-
 *
 * and at the end "reconstruct volumes=N passed=P" (pass counts need
 * --require). With -o, volume s writes into DIR/seed-s. */
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "outdir.h"
#include "recon.h"

#define PROG "hetinv-bench-reconstruct"
/* Room "/seed-<n>" takes after -o's path. */
#define SEED_FOLDER_MAX 32

static void usage(FILE *f) {
  fprintf(f,
          "usage: " PROG " [--iterations N] [--photons N] [--truth-photons N]\n"
          "                                [--threads N] [-o DIR] [--require MEAN,MAX] [--seeds A-B]\n"
          "                                [--scene FILE] [--bound-photons N [--bound-only]]\n"
          "  --iterations N  iterations of the finest stage (default: the scene's)\n"
          "  --photons N     photons per emitter of the optimiser (default: the scene's)\n"
          "  --truth-photons N  photons per emitter of the simulated measurements\n"
          "                  (default: the scene's)\n"
          "  --threads N     threads, 0 = all cores (default: the scene's)\n"
          "  -o DIR          keep the outputs in DIR (default: a temporary directory, removed)\n"
          "  --require MEAN,MAX  exit 3 if a parameter's mean or max relative error is\n"
          "                  above these (e.g. 0.07,0.15)\n"
          "  --seeds A-B     run truth volumes A..B (truth and noise seed s), one\n"
          "                  summary line each and a pass count\n"
          "  --scene FILE    a hetinv-reconstruct scene read over the built-in one\n"
          "  --bound-photons N  also the Cramer-Rao bound of each volume (N photons per\n"
          "                  emitter, 8 replicates) and each voxel's error / its bound;\n"
          "                  with --require, what an efficient recovery would score\n"
          "  --bound-only    the bound alone, no reconstruction (needs --bound-photons):\n"
          "                  with --require, the pass count the data allow\n");
}

/* Removes a directory this program created and the plain files in it. */
static void remove_tree(const char *dir) {
  DIR *d = opendir(dir);
  if (d) {
    struct dirent *ent;
    char path[4200];
    while ((ent = readdir(d)) != NULL) {
      if (strcmp(ent->d_name, ".") == 0 || strcmp(ent->d_name, "..") == 0) continue;
      snprintf(path, sizeof path, "%s/%s", dir, ent->d_name);
      unlink(path);
    }
    closedir(d);
  }
  rmdir(dir);
}

/* A volume's times: simulation, optimisation, all; iterations of all stages. */
typedef struct volume_times {
  double simulate, optimise, total;
  int64_t iterations;
} volume_times_t;

/* Prints a volume's figures (DESIGN §8), each line prefixed by `tag`: its
 * times, then per parameter its errors (e NULL: no reconstruction), its
 * bound and what an efficient recovery would score. */
static void print_figures(const char *tag, const volume_times_t *t, const recon_errors_t *e,
                          const recon_bound_t *bound, const recon_efficient_t *eff) {
  printf("%s simulate_seconds=%.3f\n", tag, t->simulate);
  if (e) printf("%s optimisation_seconds=%.3f\n", tag, t->optimise);
  printf("%s total_seconds=%.3f\n", tag, t->total);
  if (e) {
    printf("%s seconds_per_iteration=%.5f\n", tag, t->iterations > 0 ? t->optimise / (double)t->iterations : 0.0);
  }
  for (int p = 0; e && p < 3; ++p) {
    printf("%s param=%s mean_rel_error=%.4f max_rel_error=%.4f\n", tag, hetinv_param_name(p), e->mean[p],
           e->max[p]);
  }
  for (int p = 0; bound->done && p < 3; ++p) {
    printf("%s param=%s mean_rel_bound=%.4f max_rel_bound=%.4f", tag, hetinv_param_name(p), bound->mean[p],
           bound->max[p]);
    if (e && e->has_bound) {
      printf(" max_error_over_bound=%.3g rms_error_over_bound=%.3g voxels_over_2x_bound=%zu/%zu",
             e->max_over_bound[p], e->rms_over_bound[p], e->over_2x_bound[p], e->bounded[p]);
    }
    printf("%s\n", bound->positive_definite ? "" : " (estimated F not positive definite)");
    if (!isnan(eff->pass)) {
      printf("%s param=%s efficient_voxels_over_max=%.3f\n", tag, hetinv_param_name(p), eff->over_max[p]);
    }
  }
  if (!isnan(eff->pass)) {
    printf("%s efficient_pass_at_least=%.3f efficient_pass_at_most=%.3f\n", tag, eff->pass, eff->pass_at_most);
  }
}

/* 3, after naming each parameter above `require` (mean, max), or 0; 0
 * without a reconstruction (e NULL) or a requirement. */
static int check_required(const char *tag, const recon_errors_t *e, const double require[2]) {
  int status = 0;
  for (int p = 0; e && require[0] > 0.0 && p < 3; ++p) {
    if (e->mean[p] > require[0] || e->max[p] > require[1]) {
      fprintf(stderr, PROG ": %s: %s: mean/max relative error %.4f/%.4f above the required %.4f/%.4f\n", tag,
              hetinv_param_name(p), e->mean[p], e->max[p], require[0], require[1]);
      status = 3;
    }
  }
  return status;
}

/* Runs one volume of the scene end to end into sc->output; prints its
 * figures prefixed by `tag`. 0 on success, 1 on a library error, 3 when
 * `require` is set and missed. */
static int run_volume(recon_scene_t *sc, const char *tag, const double require[2], int64_t bound_photons,
                      bool bound_only, recon_errors_t *e, recon_efficient_t *eff, double *seconds) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.seed = sc->seed;
  init.thread_count = sc->threads;
  hetinv_context_t *ctx = NULL;
  int status = 0;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS) status = recon_fail(PROG, NULL, "context");
  double t0 = recon_now(), t_sim = 0.0, t_opt = 0.0;
  hetinv_medium_t *truth = NULL, *rec = NULL;
  recon_imaging_t im;
  memset(&im, 0, sizeof im);
  if (status == 0 && recon_truth_create(ctx, sc, &truth) != HETINV_SUCCESS) {
    status = recon_fail(PROG, ctx, "ground truth");
  } else if (status == 0 && recon_imaging_build(ctx, truth, sc, &im) != HETINV_SUCCESS) {
    status = recon_fail(PROG, ctx, "imaging configuration");
  }
  /* Iterations of all stages, as recon_solve() schedules them. */
  int64_t coarse = (int64_t)ceil(sc->coarse_fraction * (double)sc->iterations);
  int64_t all_iterations =
      sc->iterations + (sc->level_count - 1) * coarse + (sc->layerwise_layers > 0 ? coarse : 0);
  if (status == 0) {
    printf("%s scene=\"%s\" grid=%dx%dx%d sources=%d rows=%d threads=%d photons=%lld truth_photons=%lld "
           "iterations=%lld iterations_all_stages=%lld\n",
           tag, sc->name, (int)sc->grid[0], (int)sc->grid[1], (int)sc->grid[2], (int)im.emitter_count,
           (int)hetinv_measurements_row_count(im.set), (int)hetinv_context_thread_count(ctx),
           (long long)sc->photons, (long long)sc->truth_photons, (long long)sc->iterations,
           (long long)all_iterations);
    fflush(stdout);
    double t = recon_now();
    if (recon_simulate(ctx, sc, truth, &im) != HETINV_SUCCESS) status = recon_fail(PROG, ctx, "simulated acquisition");
    t_sim = recon_now() - t;
  }
  char msg[2048];
  memset(e, 0, sizeof *e);
  if (status == 0 && !bound_only &&
      recon_solve(ctx, sc, &im, false, true, &rec, &t_opt, msg, sizeof msg) != HETINV_SUCCESS) {
    fprintf(stderr, PROG ": %s\n", msg);
    status = 1;
  }
  recon_bound_t bound;
  memset(&bound, 0, sizeof bound);
  if (status == 0 && rec) recon_errors(truth, rec, e);
  if (status == 0 && bound_photons > 0) {
    if (recon_bound_compute(ctx, sc, truth, &im, bound_photons, 8, &bound) != HETINV_SUCCESS) {
      status = recon_fail(PROG, ctx, "bound");
    } else if (rec) {
      recon_bound_attach(&bound, truth, rec, e);
    }
  }
  const double none = (double)NAN;
  *eff = (recon_efficient_t){.over_max = {none, none, none}, .pass = none, .pass_at_most = none};
  if (status == 0 && bound.done && require[1] > 0.0) {
    recon_bound_efficient(&bound, hetinv_medium_voxel_count(truth), require[1], eff);
  }
  if (status == 0 && rec) {
    if (recon_write_outputs(ctx, sc, truth, rec, e, msg, sizeof msg) != HETINV_SUCCESS) {
      fprintf(stderr, PROG ": %s\n", msg);
      status = 1;
    }
  } else if (status == 0 && recon_bound_write(ctx, sc, truth, &bound) != HETINV_SUCCESS) {
    status = recon_fail(PROG, ctx, "bound maps");
  }
  if (status == 0) {
    *seconds = recon_now() - t0;
    const volume_times_t times = {t_sim, t_opt, *seconds, all_iterations};
    print_figures(tag, &times, rec ? e : NULL, &bound, eff);
    status = check_required(tag, rec ? e : NULL, require);
  }
  recon_bound_release(&bound);
  hetinv_medium_destroy(&rec);
  hetinv_medium_destroy(&truth);
  recon_imaging_release(&im);
  hetinv_context_destroy(&ctx);
  fflush(stdout);
  return status;
}

/* "A-B" with 0 <= A <= B < 2^31, or -1 after a message. */
static int parse_seeds(const char *text, int64_t *first, int64_t *last) {
  char *dash = NULL, *end = NULL;
  errno = 0;
  long long a = strtoll(text, &dash, 10), b = -1;
  if (dash != text && *dash == '-') b = strtoll(dash + 1, &end, 10);
  if (errno != 0 || end == NULL || end == dash + 1 || *end != '\0' || a < 0 || b < a || b > INT32_MAX) {
    fprintf(stderr, PROG ": --seeds wants A-B with 0 <= A <= B <= %d (e.g. 2-11), not '%s'\n", INT32_MAX, text);
    return -1;
  }
  *first = a;
  *last = b;
  return 0;
}

int main(int argc, char **argv) {
  recon_scene_t sc;
  recon_scene_builtin(&sc); /* --scene is read over it */
  const char *out_dir = NULL, *scene_path = NULL;
  int64_t iterations = -1, photons = -1, truth_photons = -1, threads = -1, seed_first = -1, seed_last = -1;
  int64_t bound_photons = 0;
  bool bound_only = false;
  double require[2] = {-1.0, -1.0};
  for (int i = 1; i < argc; ++i) {
    const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
    if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
      usage(stdout);
      return 0;
    } else if (strcmp(a, "--iterations") == 0 && v) {
      if (recon_parse_count(PROG, a, v, 1, INT32_MAX, &iterations) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--photons") == 0 && v) {
      if (recon_parse_count(PROG, a, v, 1, INT64_C(1) << 40, &photons) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--truth-photons") == 0 && v) {
      if (recon_parse_count(PROG, a, v, 1, INT64_C(1) << 40, &truth_photons) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--threads") == 0 && v) {
      if (recon_parse_count(PROG, a, v, 0, HETINV_MAX_THREADS, &threads) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--seeds") == 0 && v) {
      if (parse_seeds(v, &seed_first, &seed_last) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--require") == 0 && v) {
      char *comma = NULL, *end = NULL;
      require[0] = strtod(v, &comma);
      if (comma != v && *comma == ',') require[1] = strtod(comma + 1, &end);
      if (end == NULL || end == comma + 1 || *end != '\0' || !(require[0] > 0.0) || !(require[1] > 0.0)) {
        fprintf(stderr, PROG ": --require wants two positive numbers MEAN,MAX (e.g. 0.07,0.15), not '%s'\n", v);
        return 2;
      }
      ++i;
    } else if (strcmp(a, "--bound-photons") == 0 && v) {
      if (recon_parse_count(PROG, a, v, 1, INT64_C(1) << 40, &bound_photons) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--bound-only") == 0) {
      bound_only = true;
    } else if (strcmp(a, "--scene") == 0 && v) {
      scene_path = v;
      ++i;
    } else if ((strcmp(a, "-o") == 0 || strcmp(a, "--output") == 0) && v) {
      if (recon_parse_folder(PROG, a, v, SEED_FOLDER_MAX) < 0) return 2;
      out_dir = v;
      ++i;
    } else {
      fprintf(stderr, PROG ": unknown or incomplete option '%s'\n", a);
      usage(stderr);
      return 2;
    }
  }
  if (scene_path) {
    char msg[2048];
    if (recon_scene_read(scene_path, &sc, msg, sizeof msg) != 0) {
      fprintf(stderr, PROG ": %s\n", msg);
      return 2;
    }
    if (sc.render_scene[0]) {
      fprintf(stderr, PROG ": %s: acquisition.render_scene: the benchmark simulates its acquisition\n", scene_path);
      return 2;
    }
  }
  if (bound_only && bound_photons == 0) {
    fprintf(stderr, PROG ": --bound-only wants --bound-photons N (the bound's photons per emitter)\n");
    return 2;
  }
  if (iterations > 0) sc.iterations = iterations;
  if (photons > 0) sc.photons = photons;
  if (truth_photons > 0) sc.truth_photons = truth_photons;
  if (threads >= 0) sc.threads = (int32_t)threads;
  char tmp_dir[512] = "";
  outdir_t dir = {-1}; /* locked until the process ends */
  if (out_dir) {
    if (outdir_open(&dir, PROG, out_dir) != 0) return 1;
  } else {
    const char *base = getenv("TMPDIR");
    snprintf(tmp_dir, sizeof tmp_dir, "%s/hetinv-bench-reconstruct-XXXXXX", base && *base ? base : "/tmp");
    if (mkdtemp(tmp_dir) == NULL) {
      fprintf(stderr, PROG ": cannot create a temporary directory '%s': %s\n", tmp_dir, strerror(errno));
      return 1;
    }
    out_dir = tmp_dir;
  }

  int status = 0;
  recon_errors_t e;
  recon_efficient_t eff;
  double seconds = 0.0;
  if (seed_first < 0) {
    (void)recon_scene_set_output(&sc, "%s", out_dir); /* fits: recon_parse_folder */
    status = run_volume(&sc, "reconstruct", require, bound_photons, bound_only, &e, &eff, &seconds);
  } else {
    int64_t passed = 0, count = 0;
    double efficient_passes = 0.0, efficient_passes_most = 0.0; /* NaN once a volume has no bound */
    for (int64_t s = seed_first; s <= seed_last; ++s) {
      char tag[64];
      snprintf(tag, sizeof tag, "reconstruct seed=%lld", (long long)s);
      (void)recon_scene_set_output(&sc, "%s/seed-%lld", out_dir, (long long)s); /* fits: SEED_FOLDER_MAX */
      if (outdir_prepare(PROG, sc.output) != 0) {
        status = 1;
        break;
      }
      sc.truth_seed = (uint64_t)s;
      sc.noise_model.seed = (uint64_t)s;
      int st = run_volume(&sc, tag, require, bound_photons, bound_only, &e, &eff, &seconds);
      if (tmp_dir[0]) remove_tree(sc.output);
      if (st == 1) {
        status = 1;
        break;
      }
      ++count;
      passed += st == 0;
      efficient_passes += eff.pass;
      efficient_passes_most += eff.pass_at_most;
      if (bound_only) {
        printf("%s seconds=%.1f", tag, seconds);
      } else {
        printf("%s sigma_a=%.4f/%.4f sigma_s=%.4f/%.4f g=%.4f/%.4f seconds=%.1f pass=%s", tag, e.mean[0],
               e.max[0], e.mean[1], e.max[1], e.mean[2], e.max[2], seconds,
               require[0] > 0.0 ? (st == 0 ? "yes" : "no") : "-");
        for (int p = 0; e.has_bound && p < 3; ++p) {
          printf(" %s_max_error_over_bound=%.3g", hetinv_param_name(p), e.max_over_bound[p]);
        }
      }
      if (!isnan(eff.pass)) printf(" efficient_pass_at_least=%.3f efficient_pass_at_most=%.3f", eff.pass, eff.pass_at_most);
      printf("\n");
      fflush(stdout);
      if (st == 3) status = 3;
    }
    if (require[0] > 0.0 && !bound_only) {
      printf("reconstruct volumes=%lld passed=%lld", (long long)count, (long long)passed);
      if (!isnan(efficient_passes)) {
        printf(" efficient_expected_passes_at_least=%.2f efficient_expected_passes_at_most=%.2f", efficient_passes,
               efficient_passes_most);
      }
      printf("\n");
    } else {
      printf("reconstruct volumes=%lld passed=-", (long long)count);
      if (!isnan(efficient_passes)) {
        printf(" efficient_expected_passes_at_least=%.2f efficient_expected_passes_at_most=%.2f", efficient_passes,
               efficient_passes_most);
      }
      printf("\n");
    }
  }
  if (tmp_dir[0]) remove_tree(tmp_dir);
  int out_status = outdir_finish_stdout(PROG);
  return status != 0 ? status : out_status;
}
