/* hetinv-reconstruct: recover σa, σs and g of a volume from boundary
 * measurements. With no scene it runs the built-in reduced Fig. 4 scene.
 *
 *   hetinv-reconstruct [scene.json] [-o DIR] [--resume] [--quiet]
 *                      [--threads N] [--iterations N] [--photons N]
 *                      [--bound-only | --no-bound] [--bound-photons N]
 *                      [--bound-replicates N] [--bound-spacing S] [--write-scene]
 *                      [--fit-check] [--fit-photons N] [--fit-replicates N]
 *                      [--gradient-check N]
 *
 * --bound-only computes the Cramér–Rao bound of the configuration at the
 * truth (bound.c) and stops; otherwise the bound is written beside the
 * recovery and errors.csv gains achieved/bound, unless --no-bound. Past
 * the dense Fisher matrix's HETINV_FISHER_MAX_ENTRIES entries the bound
 * is the local one at radius 0, from F's per-voxel blocks
 * (hetinv_estimator_fisher_blocks, probes on voxels --bound-spacing
 * apart, default 2: 1 + 24 passes per replicate).
 *
 * A scene whose "acquisition" names a render scene and measured files
 * (docs/reconstruct-format.md) is reconstructed from those files alone
 * (measured.c): no simulation, the truth only if named.
 *
 * --fit-check, where the truth is known, then asks whether the miss that
 * is left comes from the data or from the optimizer: it renders the truth
 * and the recovery against the data (--fit-photons per source, default
 * 20000; --fit-replicates pairs for the run's own loss, default 4) and
 * says which fits them better (fit_check.h), into fit_check.csv. A
 * recovery that fits better than the truth is as far as these data lead
 * any optimizer.
 *
 * --gradient-check N, where the truth is known, asks the same by the
 * gradient (gradient_check.h): the run's loss gradient over N independent
 * renders at the truth and at the recovery (is each missed voxel still
 * pulled back, or does it sit where the loss is flat?) and dᵀF d, how far
 * apart the data hold the two against what an efficient recovery would
 * show; maps in gradient_check.exr, the summary in gradient_check.csv.
 * One MPI rank.
 *
 * --write-scene writes a simulated scene (the built-in one, or a scene's
 * medium/imaging preset) as the files a user edits and runs: the render
 * scene of its acquisition, the truth, and the reconstruction from the
 * rendered files (preset.c), then stops.
 *
 * Exit status: 0 success, 1 failure (message on stderr), 2 usage error. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fit_check.h"
#include "gradient_check.h"
#include "interrupted.h"
#include "outdir.h"
#include "runrecord.h"
#include "recon.h"

#ifdef HETINV_RECONSTRUCT_MPI
#include <mpi.h>
#endif

/* --help prints to stdout (for a pager), a usage error to stderr. */
static void print_usage(FILE *to, const char *what) {
  fprintf(to,
          "hetinv-reconstruct: %s\n"
          "usage: hetinv-reconstruct [scene.json] [-o DIR] [--resume] [--quiet]\n"
          "                          [--threads N] [--iterations N] [--photons N]\n"
          "                          [--bound-only | --no-bound] [--bound-photons N] [--bound-replicates N]\n"
          "                          [--bound-spacing S] [--write-scene]\n"
          "                          [--fit-check] [--fit-photons N] [--fit-replicates N]\n"
          "                          [--gradient-check N]\n"
          "Without a scene, runs the built-in reduced Fig. 4 scene.\n",
          what);
}

static int usage(const char *what) {
  print_usage(recon_err(), what);
  return 2;
}

/* Under MPI every rank runs the program on the same folder and rank 0
 * writes; so rank 0 alone locks the folder and every rank learns whether
 * it could (one stopping alone would leave the others waiting for it). */
static int world_rank(void) {
  int rank = 0;
#ifdef HETINV_RECONSTRUCT_MPI
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
#endif
  return rank;
}

static int world_size(void) {
  int size = 1;
#ifdef HETINV_RECONSTRUCT_MPI
  MPI_Comm_size(MPI_COMM_WORLD, &size);
#endif
  return size;
}

static int rank0_status(int status) {
#ifdef HETINV_RECONSTRUCT_MPI
  MPI_Bcast(&status, 1, MPI_INT, 0, MPI_COMM_WORLD);
#endif
  return status;
}

/* The largest of every rank's status (0 where all succeeded). */
static int world_max(int status) {
#ifdef HETINV_RECONSTRUCT_MPI
  int all = status;
  MPI_Allreduce(&status, &all, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  status = all;
#endif
  return status;
}

/* After a step some ranks may have failed alone (rank 0's writes, a file
 * one node cannot read), before the next collective: every rank's status
 * becomes 1 if any rank's is (the failing one said why). */
static int agreed(const hetinv_context_t *ctx, int status) {
  return hetinv_context_agree(ctx, status != 0 ? HETINV_ERROR_IO : HETINV_SUCCESS) != HETINV_SUCCESS;
}

/* The options that depend on what the scene says (usage errors, exit 2). */
static int check_scene_options(const recon_scene_t *sc, bool bound_only, bool write_scene, bool fit,
                               int64_t gradient_replicates) {
  const bool files = sc->render_scene[0] != '\0';
  if (write_scene && (files || bound_only)) {
    return usage(files ? "--write-scene: the scene already reads measured files (acquisition.render_scene)"
                       : "--write-scene and --bound-only exclude each other");
  }
  /* From files the bound takes the noise from the standard errors given,
   * and is evaluated at the truth if one is named, else at the recovery. */
  if (files && bound_only && !sc->has_truth) {
    return usage("--bound-only: from measured files the bound is evaluated at the truth (truth.vol), or "
                 "without one after the recovery, at it");
  }
  if (files && bound_only && sc->std_errors[0] == '\0') {
    return usage("--bound-only: the bound needs the measurements' standard errors (acquisition.std_errors)");
  }
  if (fit && (bound_only || write_scene)) return usage("--fit-check needs a recovery: not with --bound-only or --write-scene");
  if (fit && files && !sc->has_truth) {
    return usage("--fit-check compares the recovery with the truth, and this scene names none (truth)");
  }
  if (fit && sc->gain_mode != HETINV_GAIN_NONE) {
    return usage("--fit-check renders without sensor gains: not with acquisition gains estimated (gain_mode)");
  }
  if (gradient_replicates > 0 && (bound_only || write_scene)) {
    return usage("--gradient-check needs a recovery: not with --bound-only or --write-scene");
  }
  if (gradient_replicates > 0 && files && !sc->has_truth) {
    return usage("--gradient-check compares the recovery with the truth, and this scene names none (truth)");
  }
  if (gradient_replicates > 0 && sc->gain_mode != HETINV_GAIN_NONE) {
    return usage("--gradient-check measures the data's Fisher information without sensor gains: not with "
                 "acquisition gains estimated (gain_mode)");
  }
  /* Both run on one rank: refused here, on every rank alike, not after the
   * work (--bound-only would otherwise exit 0 having written nothing). */
  if ((bound_only || gradient_replicates > 0) && world_size() > 1) {
    char what[160];
    snprintf(what, sizeof what, "%s runs on one MPI rank (this run has %d)",
             bound_only ? "--bound-only" : "--gradient-check", world_size());
    return usage(what);
  }
  return 0;
}

static int run(int argc, char **argv, outdir_t *dir, run_record_t *record) {
  recon_scene_t sc;
  recon_scene_default(&sc);
  const char *scene_path = NULL, *out_dir = NULL;
  bool resume = false, quiet = false;
  int64_t threads = -1, iterations = -1, photons = -1;
  bool bound_only = false, no_bound = false, write_scene = false;
  int64_t bound_photons = -1, bound_replicates = 8, bound_spacing = 0;
  bool fit = false;
  int64_t fit_photons = 20000, fit_replicates = 4, gradient_replicates = 0;
  for (int i = 1; i < argc; ++i) {
    const char *a = argv[i];
    if (strcmp(a, "-o") == 0 || strcmp(a, "--output") == 0) {
      if (++i == argc) return usage("-o needs a directory");
      if (recon_parse_folder("hetinv-reconstruct", a, argv[i], 0) < 0) return 2;
      out_dir = argv[i];
    } else if (strcmp(a, "--resume") == 0) {
      resume = true;
    } else if (strcmp(a, "--quiet") == 0) {
      quiet = true;
    } else if (strcmp(a, "--threads") == 0) {
      if (recon_parse_count("hetinv-reconstruct", a, i + 1 < argc ? argv[++i] : NULL, 0, HETINV_MAX_THREADS, &threads) < 0) return 2;
    } else if (strcmp(a, "--iterations") == 0) {
      if (recon_parse_count("hetinv-reconstruct", a, i + 1 < argc ? argv[++i] : NULL, 1, INT32_MAX, &iterations) < 0) return 2;
    } else if (strcmp(a, "--photons") == 0) {
      if (recon_parse_count("hetinv-reconstruct", a, i + 1 < argc ? argv[++i] : NULL, 1, INT64_C(1) << 40, &photons) < 0) return 2;
    } else if (strcmp(a, "--bound-only") == 0) {
      bound_only = true;
    } else if (strcmp(a, "--write-scene") == 0) {
      write_scene = true;
    } else if (strcmp(a, "--no-bound") == 0) {
      no_bound = true;
    } else if (strcmp(a, "--bound-photons") == 0) {
      if (recon_parse_count("hetinv-reconstruct", a, i + 1 < argc ? argv[++i] : NULL, 1, INT64_C(1) << 40, &bound_photons) < 0) return 2;
    } else if (strcmp(a, "--bound-spacing") == 0) {
      if (recon_parse_count("hetinv-reconstruct", a, i + 1 < argc ? argv[++i] : NULL, 1, 16, &bound_spacing) < 0) return 2;
    } else if (strcmp(a, "--bound-replicates") == 0) {
      if (recon_parse_count("hetinv-reconstruct", a, i + 1 < argc ? argv[++i] : NULL, 2, HETINV_FISHER_MAX_REPLICATES, &bound_replicates) < 0) return 2;
    } else if (strcmp(a, "--fit-check") == 0) {
      fit = true;
    } else if (strcmp(a, "--fit-photons") == 0) {
      if (recon_parse_count("hetinv-reconstruct", a, i + 1 < argc ? argv[++i] : NULL, 1, INT64_C(1) << 40, &fit_photons) < 0) return 2;
    } else if (strcmp(a, "--gradient-check") == 0) {
      if (recon_parse_count("hetinv-reconstruct", a, i + 1 < argc ? argv[++i] : NULL, 2, 1000, &gradient_replicates) < 0) return 2;
    } else if (strcmp(a, "--fit-replicates") == 0) {
      if (recon_parse_count("hetinv-reconstruct", a, i + 1 < argc ? argv[++i] : NULL, 2, 1000, &fit_replicates) < 0) return 2;
    } else if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
      if (world_rank() == 0) print_usage(stdout, "recover sigma_a, sigma_s and g from boundary measurements");
      return 0;
    } else if (a[0] == '-') {
      char msg[300];
      snprintf(msg, sizeof msg, "unknown option '%s'", a);
      return usage(msg);
    } else if (scene_path) {
      return usage("give at most one scene");
    } else {
      scene_path = a;
    }
  }
  if (bound_only && no_bound) return usage("--bound-only and --no-bound exclude each other");
  char msg[4096];
  int early = 0;
  if (scene_path == NULL) {
    recon_scene_builtin(&sc);
  } else if (recon_scene_read(scene_path, &sc, msg, sizeof msg) < 0) {
    fprintf(recon_err(), "hetinv-reconstruct: %s\n", msg);
    early = 1;
  }
  if (early == 0) early = check_scene_options(&sc, bound_only, write_scene, fit, gradient_replicates);
  /* Under MPI every rank reads the scene itself: one that cannot (a file
   * missing on its node) or reads another copy stops every rank here, which
   * left the others waiting in the next collective, and its message is
   * printed at the end (main). */
  early = world_max(early);
  if (early != 0) return early;
  const bool files = sc.render_scene[0] != '\0';
  const bool no_std_errors = files && sc.std_errors[0] == '\0';
  if (no_std_errors) no_bound = true;
  if (out_dir) (void)recon_scene_set_output(&sc, "%s", out_dir); /* fits: recon_parse_folder */
  if (threads >= 0) sc.threads = (int32_t)threads;
  if (iterations > 0) sc.iterations = iterations;
  if (photons > 0) sc.photons = photons;
  /* Before any simulation: a folder we can write, locked for this run
   * (a --resume run takes it again once the interrupted one is gone). */
  int opened = 0;
  if (world_rank() == 0) {
    opened = outdir_open(dir, "hetinv-reconstruct", sc.output);
    if (opened == 0) opened = run_record_begin(record, "hetinv-reconstruct", sc.output, argc, argv, resume);
  }
  if (rank0_status(opened) != 0) return 1;
  if (world_rank() == 0) {
    char hint[1200];
    snprintf(hint, sizeof hint, "hetinv-reconstruct: stopped; the same command with --resume continues from the "
             "last checkpoint, %s/checkpoint.bin, if the run wrote one", sc.output);
    interrupted_hint(hint);
  }

  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.seed = sc.seed;
  init.thread_count = sc.threads;
  hetinv_context_t *ctx = NULL;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS) return recon_fail("hetinv-reconstruct", NULL, "context");
  double t0 = recon_now();
  int status = 0;
  /* Under MPI every rank runs the same reconstruction (the estimator shares
   * the work and returns the same values everywhere); rank 0 talks and writes. */
  bool root = hetinv_context_rank(ctx) == 0;
  quiet = quiet || !root;
  hetinv_medium_t *truth = NULL, *rec = NULL;
  recon_imaging_t im;
  memset(&im, 0, sizeof im);
  if (files) {
    /* The render scene and the measured files; the truth, if named, only for the errors. */
    if (recon_files_load(ctx, &sc, &im, msg, sizeof msg) < 0) {
      fprintf(recon_err(), "hetinv-reconstruct: %s\n", msg);
      status = 1;
    } else if (sc.has_truth && recon_truth_create(ctx, &sc, &truth) != HETINV_SUCCESS) {
      status = recon_fail("hetinv-reconstruct", ctx, "truth.vol");
    }
  } else if (recon_truth_create(ctx, &sc, &truth) != HETINV_SUCCESS) {
    status = recon_fail("hetinv-reconstruct", ctx, "ground truth");
  } else if (recon_imaging_build(ctx, truth, &sc, &im) != HETINV_SUCCESS) {
    status = recon_fail("hetinv-reconstruct", ctx, "imaging configuration");
  }
  status = agreed(ctx, status);
  if (status == 0 && root && files) {
    printf("hetinv-reconstruct: %s: %d x %d x %d voxels, %d rows, %zu values read from %s\n", sc.name,
           (int)sc.grid[0], (int)sc.grid[1], (int)sc.grid[2], (int)hetinv_measurements_row_count(im.set),
           hetinv_measurements_value_count(im.set), sc.measured);
    if (sc.dark_rows > 0) {
      printf("hetinv-reconstruct: %d of %d rows left out: no photon reached them (zeros with zero errors)\n",
             (int)sc.dark_rows, (int)hetinv_measurements_row_count(im.set));
    }
    if (isfinite(sc.saturation)) {
      printf("hetinv-reconstruct: acquisition.saturation %g: %zu of %zu values at or above it masked\n",
             sc.saturation, sc.saturated, hetinv_measurements_value_count(im.set));
    }
    fflush(stdout);
  } else if (status == 0 && root) {
    printf("hetinv-reconstruct: %s: %d x %d x %d voxels, %d sources, %d rows, %zu values\n", sc.name,
           (int)sc.grid[0], (int)sc.grid[1], (int)sc.grid[2], (int)im.emitter_count,
           (int)hetinv_measurements_row_count(im.set), hetinv_measurements_value_count(im.set));
    fflush(stdout);
  }
  char path[1200];
  if (status == 0 && write_scene) {
    if (root && recon_preset_write(ctx, &sc, truth, &im, sc.output, msg, sizeof msg) < 0) {
      fprintf(recon_err(), "hetinv-reconstruct: %s\n", msg);
      status = 1;
    } else if (root) {
      printf("wrote %s/{render.json, reconstruct.json, truth_*.vol}; to render and reconstruct from the files:\n"
             "  hetinv-render %s/render.json -o %s/data\n  hetinv-reconstruct %s/reconstruct.json -o %s/rec\n",
             sc.output, sc.output, sc.output, sc.output, sc.output);
    }
  }
  if (write_scene) {
    /* written (or failed) above: nothing to simulate or recover */
  } else if (bound_only || files) {
    /* the bound needs the configuration and the truth only; files were read above */
  } else if (status == 0 && sc.measurements[0]) {
    if (recon_measurements_read(ctx, &im, sc.measurements, msg, sizeof msg) != HETINV_SUCCESS) {
      fprintf(recon_err(), "hetinv-reconstruct: measurements: %s\n", msg);
      status = 1;
    } else if (sc.loss_clip_errors != RECON_CLIP_DATA && !recon_has_clip_scales(im.set)) {
      fprintf(recon_err(), "hetinv-reconstruct: measurements: %s has no clip scale channels; "
                      "estimator.loss_clip_errors \"%s\" needs them (written by a run that used it)\n",
              sc.measurements, recon_clip_errors_names[sc.loss_clip_errors]);
      status = 1;
    }
  } else if (status == 0) {
    if (recon_simulate(ctx, &sc, truth, &im) != HETINV_SUCCESS) {
      status = recon_fail("hetinv-reconstruct", ctx, "simulated acquisition");
    } else {
      snprintf(path, sizeof path, "%s/measurements.exr", sc.output);
      if (root && recon_measurements_write(ctx, &im, path) != HETINV_SUCCESS) status = recon_fail("hetinv-reconstruct", ctx, path);
      if (status == 0 && !quiet) printf("simulated the measurements in %.1f s: %s\n", recon_now() - t0, path);
    }
  }
  if (status == 0 && root && !write_scene && sc.min_snr > 0.0 && (files || !bound_only)) recon_print_in_loss("hetinv-reconstruct", &sc, &im);
  status = agreed(ctx, status);
  recon_bound_t bound;
  memset(&bound, 0, sizeof bound);
  const int64_t bphotons = bound_photons > 0 ? bound_photons : sc.photons;
  if (bound_spacing > 0) sc.bound_spacing = (int32_t)bound_spacing;
  if (status == 0 && !write_scene && truth != NULL && (bound_only || !no_bound)) {
    status = recon_bound_run("hetinv-reconstruct", ctx, &sc, truth, &im, bphotons, (int32_t)bound_replicates, root,
                             false, &bound);
  }
  if (status == 0 && root && bound_only && bound.done) printf("wrote %s/{bound.exr, bound_*.png}\n", sc.output);
  double seconds = 0.0;
  if (status == 0 && !bound_only && !write_scene &&
      recon_solve(ctx, &sc, &im, resume, quiet, &rec, &seconds, msg, sizeof msg) != HETINV_SUCCESS) {
    if (msg[0] != '\0') fprintf(recon_err(), "hetinv-reconstruct: %s\n", msg);
    status = 1;
  }
  status = agreed(ctx, status);
  if (status == 0 && truth == NULL && !no_bound && !write_scene) {
    status = recon_bound_run("hetinv-reconstruct", ctx, &sc, rec, &im, bphotons, (int32_t)bound_replicates, root,
                             true, &bound);
  } else if (status == 0 && root && no_std_errors && !quiet) {
    printf("no bound: the measurements have no standard errors (acquisition.std_errors)\n");
  }
  if (status == 0 && root && !bound_only && truth == NULL) {
    printf("optimisation %.1f s, total %.1f s (no truth given: no errors)\n", seconds, recon_now() - t0);
    if (recon_write_outputs(ctx, &sc, NULL, rec, NULL, msg, sizeof msg) != HETINV_SUCCESS) {
      fprintf(recon_err(), "hetinv-reconstruct: %s\n", msg);
      status = 1;
    } else {
      printf("wrote %s/{recovered_*.vol, maps.exr, maps_*.png, loss.csv%s%s}\n", sc.output,
             sc.gain_mode != HETINV_GAIN_NONE ? ", gains.csv" : "", bound.done ? ", bound.exr, bound_*.png" : "");
    }
  } else if (status == 0 && root && !bound_only && !write_scene) {
    recon_errors_t e;
    recon_errors(truth, rec, &e);
    recon_bound_attach(&bound, truth, rec, &e);
    printf("\nrelative error of the recovery (%zu voxels):\n", hetinv_medium_voxel_count(truth));
    printf("  parameter   mean      max%s\n",
           e.has_bound ? "       achieved/bound  max voxel error/bound  voxels > 2x bound" : "");
    for (int p = 0; p < 3; ++p) {
      printf("  %-9s %6.2f %%  %6.2f %%", hetinv_param_name(p), 100.0 * e.mean[p], 100.0 * e.max[p]);
      if (e.has_bound) {
        printf("  %8.3g        %8.3g               %zu of %zu", e.achieved_over_bound[p], e.max_over_bound[p],
               e.over_2x_bound[p], e.bounded[p]);
      }
      printf("\n");
    }
    if (e.has_bound) {
      printf("  (an efficient unbiased recovery: achieved/bound near 0.8, about 4.6 %% of the voxels\n"
             "   above 2x their bound by chance; far more means the optimizer, not the data)\n");
    }
    printf("optimisation %.1f s, total %.1f s\n", seconds, recon_now() - t0);
    if (recon_write_outputs(ctx, &sc, truth, rec, &e, msg, sizeof msg) != HETINV_SUCCESS) {
      fprintf(recon_err(), "hetinv-reconstruct: %s\n", msg);
      status = 1;
    } else {
      printf("wrote %s/{recovered_*.vol, maps.exr, maps_*.png, loss.csv, errors.csv%s%s}\n", sc.output,
             sc.gain_mode != HETINV_GAIN_NONE ? ", gains.csv" : "",
             bound.done ? ", bound.exr, bound_*.png" : "");
    }
  }
  status = agreed(ctx, status); /* rank 0 wrote the outputs */
  if (status == 0 && fit && truth != NULL && rec != NULL) {
    /* Every rank renders; rank 0 reports. */
    fit_check_t f;
    if (fit_check_compare(ctx, &sc, im.set, truth, rec, fit_photons, (int32_t)fit_replicates, &f) != HETINV_SUCCESS) {
      status = recon_fail("hetinv-reconstruct", ctx, "fit check");
    } else if (root) {
      fit_check_print(&sc, fit_photons, &f);
      if (fit_check_store(&sc, fit_photons, &f) != 0) {
        fprintf(recon_err(), "hetinv-reconstruct: %s/fit_check.csv: %s\n", sc.output, strerror(errno));
        status = 1;
      } else {
        printf("wrote %s/fit_check.csv\n", sc.output);
      }
    }
  }
  if (status == 0 && gradient_replicates > 0 && truth != NULL && rec != NULL) {
    gradient_check_t g;
    if (gradient_check_compare(ctx, &sc, im.set, truth, rec, (int32_t)gradient_replicates, 0.15, &g, msg,
                                      sizeof msg) != HETINV_SUCCESS) {
      fprintf(recon_err(), "hetinv-reconstruct: gradient check: %s\n", msg);
      status = 1;
    } else {
      gradient_check_print(&sc, &g);
      gradient_check_release(&g);
    }
  }
  recon_bound_release(&bound);
  hetinv_medium_destroy(&rec);
  hetinv_medium_destroy(&truth);
  recon_imaging_release(&im);
  hetinv_context_destroy(&ctx);
  return status;
}

#ifdef HETINV_RECONSTRUCT_MPI
/* Every rank must run the same command (mpirun's "A : B" form can give
 * them others): a usage error on one rank alone, or other iterations or
 * photons, would leave the others waiting or mix two runs. Compared by an
 * FNV-1a hash of the arguments, its maximum and its complement's over the
 * ranks. */
static bool same_command_line(int argc, char **argv) {
  uint64_t h = RECON_FNV_OFFSET;
  for (int i = 1; i < argc; ++i) h = recon_fnv1a(h, argv[i], strlen(argv[i]) + 1); /* with its '\0' */
  unsigned long long mine[2] = {h, ~h}, all[2] = {0, 0};
  MPI_Allreduce(mine, all, 2, MPI_UNSIGNED_LONG_LONG, MPI_MAX, MPI_COMM_WORLD);
  return all[0] == mine[0] && all[1] == mine[1];
}
#endif

int main(int argc, char **argv) {
#ifdef HETINV_RECONSTRUCT_MPI
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  if (!same_command_line(argc, argv)) {
    if (world_rank() == 0) { /* every rank finds it */
      fprintf(stderr, "hetinv-reconstruct: the MPI ranks were given different arguments; every rank must run "
                      "the same command\n");
    }
    MPI_Finalize();
    return 2;
  }
  if (world_rank() != 0) recon_err_hold();
#endif
  outdir_t dir = {-1};
  run_record_t record = RUN_RECORD_INIT;
  int status = run(argc, argv, &dir, &record);
  if (outdir_finish_stdout("hetinv-reconstruct") != 0) status = 1;
  status = run_record_end(&record, status);
  outdir_close(&dir);
#ifdef HETINV_RECONSTRUCT_MPI
  /* Each failure once: the lowest rank that wrote a message prints its
   * messages (rank 0 printed its own as they came), the others' are
   * dropped. They are copies of the same failure (a damaged checkpoint
   * every rank read) or, rarely, another failure of their own after the
   * one printed, which ended the run already. */
  int mine = recon_erred() ? world_rank() : world_size(), first = 0;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  recon_err_release(first == world_rank());
  MPI_Finalize();
#endif
  return status;
}
