/* hetinv-render: renders the measurements a JSON scene describes
 * (docs/scene-format.md) and writes each orthographic sensor's images as
 * OpenEXR stacks with PNG previews; prints totals, as JSON on request.
 *
 *   usage: hetinv-render scene.json [-o outdir] [--photons N] [--seed S]
 *                        [--threads T] [--totals-json] [--write-medium] [--quiet]
 *
 * Exit status: 0 success; 1 a malformed scene or a failed render or write
 * (the message names the field or file); 2 a usage error.
 */
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "outdir.h"
#include "runrecord.h"
#include "camera.h"
#include "output.h"
#include "scene.h"

static const char *const usage_text =
    "usage: hetinv-render scene.json [-o outdir] [--photons N] [--seed S] [--threads T]\n"
    "                     [--totals-json] [--write-medium] [--quiet]\n"
    "  -o, --output DIR  folder of the images (created; default out/<scene name>)\n"
    "  --photons N       photons per emitter (overrides the scene's \"photons\")\n"
    "  --seed S          base random seed, 0 to 2^64-1 (overrides \"seed\")\n"
    "  --threads T       worker threads, 0 for all (overrides \"threads\")\n"
    "  --totals-json     print the totals as JSON on stdout (other messages go to stderr)\n"
    "  --write-medium    also write the medium as medium_<param>.vol (a truth to compare with)\n"
    "  --quiet           print nothing but errors (and the JSON)\n"
    "The scene format is described in docs/scene-format.md.\n";

typedef struct options {
  const char *scene, *outdir;
  int has_photons, has_seed, has_threads, totals_json, quiet, write_medium;
  unsigned long long photons, seed, threads;
} options_t;

static int usage_error(const char *fmt, ...) JR_PRINTF(1, 2);
static int usage_error(const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  fprintf(stderr, "hetinv-render: ");
  vfprintf(stderr, fmt, ap);
  fprintf(stderr, "\n%s", usage_text);
  va_end(ap);
  return 2;
}

/* A whole decimal number in [lo, hi]. */
static int parse_count(const char *text, unsigned long long lo, unsigned long long hi,
                       unsigned long long *out) {
  if (text[0] < '0' || text[0] > '9') return -1;
  errno = 0;
  char *end = NULL;
  unsigned long long v = strtoull(text, &end, 10);
  if (errno != 0 || *end != '\0' || v < lo || v > hi) return -1;
  *out = v;
  return 0;
}

/* Returns -1 to go on, else the exit status. */
static int parse_options(int argc, char **argv, options_t *o) {
  memset(o, 0, sizeof *o);
  for (int i = 1; i < argc; ++i) {
    const char *arg = argv[i], *value = NULL;
    char name[32] = "";
    if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
      fputs(usage_text, stdout);
      return 0;
    }
    if (strcmp(arg, "--totals-json") == 0) {
      o->totals_json = 1;
      continue;
    }
    if (strcmp(arg, "--write-medium") == 0) {
      o->write_medium = 1;
      continue;
    }
    if (strcmp(arg, "--quiet") == 0 || strcmp(arg, "-q") == 0) {
      o->quiet = 1;
      continue;
    }
    if (arg[0] != '-' || strcmp(arg, "-") == 0) {
      if (o->scene != NULL) return usage_error("more than one scene file ('%s')", arg);
      o->scene = arg;
      continue;
    }
    /* options with a value: "--name value" or "--name=value" */
    const char *eq = strchr(arg, '=');
    if (eq != NULL && arg[1] == '-' && (size_t)(eq - arg) < sizeof name) {
      snprintf(name, sizeof name, "%.*s", (int)(eq - arg), arg);
      value = eq + 1;
    } else {
      snprintf(name, sizeof name, "%.31s", arg);
    }
    int known = strcmp(name, "-o") == 0 || strcmp(name, "--output") == 0 ||
                strcmp(name, "--photons") == 0 || strcmp(name, "--seed") == 0 ||
                strcmp(name, "--threads") == 0;
    if (!known) return usage_error("unknown option '%s'", arg);
    if (value == NULL) {
      if (i + 1 >= argc) return usage_error("%s needs a value", name);
      value = argv[++i];
    }
    if (strcmp(name, "-o") == 0 || strcmp(name, "--output") == 0) {
      if (value[0] == '\0') return usage_error("%s needs a folder name", name);
      o->outdir = value;
    } else if (strcmp(name, "--photons") == 0) {
      if (parse_count(value, 1, 9007199254740992ULL, &o->photons) < 0) {
        return usage_error("--photons: '%s' is not a whole number from 1 to 2^53", value);
      }
      o->has_photons = 1;
    } else if (strcmp(name, "--seed") == 0) {
      if (parse_count(value, 0, ~0ULL, &o->seed) < 0) {
        return usage_error("--seed: '%s' is not a whole number from 0 to 2^64-1", value);
      }
      o->has_seed = 1;
    } else {
      if (parse_count(value, 0, HETINV_MAX_THREADS, &o->threads) < 0) {
        return usage_error("--threads: '%s' is not a whole number from 0 to %d", value, HETINV_MAX_THREADS);
      }
      o->has_threads = 1;
    }
  }
  if (o->scene == NULL) return usage_error("%s", "no scene file given");
  return -1;
}

/* out/<file name without folder and .json> */
static void default_outdir(const char *scene, char *out, size_t size) {
  const char *base = strrchr(scene, '/');
  base = base ? base + 1 : scene;
  size_t n = strlen(base);
  if (n > 5 && strcmp(base + n - 5, ".json") == 0) n -= 5;
  snprintf(out, size, "out/%.*s", (int)n, base);
}

/* The scene's medium as outdir/medium_<param>.vol: a rendered truth that a
 * reconstruction from the images can be compared with. */
static int write_medium(const scene_t *sc, hetinv_context_t *ctx, const char *outdir, FILE *log, jr_t *jr) {
  char path[4200];
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    snprintf(path, sizeof path, "%s/medium_%s.vol", outdir, hetinv_param_name(p));
    hetinv_result_t r = hetinv_medium_write_vol(sc->medium, p, path);
    if (r != HETINV_SUCCESS) return scene_lib_fail(jr, path, ctx, r);
  }
  if (log != NULL) fprintf(log, "wrote %s/medium_{sigma_a,sigma_s,g}.vol\n", outdir);
  return 0;
}

int main(int argc, char **argv) {
  options_t opt;
  int status = parse_options(argc, argv, &opt);
  if (status >= 0) return status;

  status = 1;
  jr_t jr;
  memset(&jr, 0, sizeof jr);
  scene_t sc;
  hetinv_context_t *ctx = NULL;
  hetinv_estimator_t *est = NULL;
  outdir_t dir = {-1};
  run_record_t record = RUN_RECORD_INIT;
  double *values = NULL;
  FILE *log = opt.quiet ? NULL : (opt.totals_json ? stderr : stdout);
  char outdir[4096];
  if (opt.outdir != NULL) {
    snprintf(outdir, sizeof outdir, "%s", opt.outdir);
  } else {
    default_outdir(opt.scene, outdir, sizeof outdir);
  }

  if (scene_load(&sc, opt.scene, &jr) < 0) goto fail;
  if (opt.has_photons) sc.photons = (int64_t)opt.photons;
  if (opt.has_seed) sc.seed = opt.seed;
  if (opt.has_threads) sc.threads = (int32_t)opt.threads;

  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.seed = sc.seed;
  init.thread_count = sc.threads;
  hetinv_result_t r = hetinv_context_create(&init, &ctx);
  if (r != HETINV_SUCCESS) {
    scene_lib_fail(&jr, opt.has_threads ? "--threads" : "threads", NULL, r);
    goto fail;
  }
  if (scene_build(&sc, ctx, &jr) < 0) goto fail;

  /* Orthographic rows write images: their folder is checked and locked
   * before the render (released by the kernel however the process ends). */
  int images = 0;
  for (int i = 0; i < sc.row_count; ++i) images |= sc.sensors[sc.rows[i].sensor].kind == SENSOR_ORTHOGRAPHIC;
  if (images || opt.write_medium) {
    if (outdir_open(&dir, "hetinv-render", outdir) != 0) goto done;
    if (run_record_begin(&record, "hetinv-render", outdir, argc, argv, false) != 0) goto done;
  }

  r = hetinv_estimator_create(ctx, &est);
  if (r != HETINV_SUCCESS) {
    scene_lib_fail(&jr, "estimator", ctx, r);
    goto fail;
  }
  if (scene_configure_estimator(&sc, est, opt.has_photons ? "--photons" : "photons", &jr) < 0) goto fail;

  size_t count = hetinv_measurements_value_count(sc.set);
  values = malloc(3 * count * sizeof *values);
  if (values == NULL) {
    jr_fail(&jr, "measurements", "out of memory for %zu values", count);
    goto fail;
  }
  render_result_t res;
  memset(&res, 0, sizeof res);
  res.values = values;
  res.std_errors = values + count;
  res.ballistic = values + 2 * count;
  res.threads = hetinv_context_thread_count(ctx);
  hetinv_estimator_get_param(est, HETINV_ESTIMATOR_BATCHES, &res.batches);
  hetinv_estimator_get_param(est, HETINV_ESTIMATOR_STREAM, &res.stream);
  if (log != NULL) {
    fprintf(log, "%s: %s medium of %d x %d x %d voxels, %d emitter%s, %d sensor%s, %d row%s; "
            "%lld photons per emitter, seed %llu\n", sc.path, sc.medium_kind, (int)sc.dims[0],
            (int)sc.dims[1], (int)sc.dims[2], sc.emitter_count, sc.emitter_count == 1 ? "" : "s",
            sc.sensor_count, sc.sensor_count == 1 ? "" : "s", sc.row_count,
            sc.row_count == 1 ? "" : "s", (long long)sc.photons, (unsigned long long)sc.seed);
    fflush(log);
  }
  r = hetinv_estimator_render(est, sc.medium, sc.set, values, values + count, values + 2 * count, count);
  if (r != HETINV_SUCCESS) {
    scene_lib_fail(&jr, "", ctx, r);
    goto fail;
  }
  res.stats.size = sizeof res.stats;
  r = hetinv_estimator_get_stats(est, &res.stats);
  if (r != HETINV_SUCCESS) {
    scene_lib_fail(&jr, "", ctx, r);
    goto fail;
  }

  if (camera_record(&sc, ctx, values, values + count, &jr) < 0) goto fail;
  if (images && output_write_images(&sc, ctx, &res, outdir, log, &jr) < 0) goto fail;
  if (opt.write_medium && write_medium(&sc, ctx, outdir, log, &jr) < 0) goto fail;
  output_print_summary(&sc, &res, log);
  if (opt.totals_json && output_print_totals_json(&sc, &res, stdout) < 0) {
    fprintf(stderr, "hetinv-render: out of memory writing the totals\n");
    goto done;
  }
  status = 0;
  goto done;

fail:
  fprintf(stderr, "hetinv-render: %s\n", jr.message);
done:
  free(values);
  hetinv_estimator_destroy(&est);
  scene_destroy(&sc);
  hetinv_context_destroy(&ctx);
  if (outdir_finish_stdout("hetinv-render") != 0) status = 1;
  status = run_record_end(&record, status);
  outdir_close(&dir);
  return status;
}
