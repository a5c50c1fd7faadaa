/* hetinv-mpi-equivalence: a small render, gradient and loss gradient whose
 * results must be bitwise the same for any rank count and any thread
 * count, and the same as the serial computation.
 *
 *   hetinv-mpi-equivalence [--out FILE] [--emitters E]
 *
 * Every number is written to FILE (on rank 0 only) as "name index %a", so
 * that runs with different rank counts, or from a build without MPI, can
 * be compared with cmp. In an MPI build the program runs under mpirun:
 * each rank computes the results twice, once distributed over
 * MPI_COMM_WORLD with 2 threads per rank and once alone (MPI_COMM_SELF,
 * 1 thread), and fails unless the two are bitwise identical on every rank.
 * Without MPI it compares 2 threads with 1 thread. --emitters (1 to 5,
 * default 5) uses the first E beams only, so that some ranks have no
 * emitter to trace. Exit status 0 means identical. */
#include <hetinv/hetinv.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef HETINV_TEST_MPI
#include <hetinv/mpi.h>
#endif

enum { MAX_EMITTERS = 5, PHOTONS = 3000, BATCHES = 8 };

static int emitters = MAX_EMITTERS;

typedef struct results {
  size_t count, k, k_coarse;
  double *values, *std_errors, *ballistic; /* count */
  double stats[17];                       /* hetinv_render_stats_t without seconds */
  double *grad, *grad_se;                 /* k */
  double loss, *rendered, *loss_grad;     /* count, k_coarse */
} results_t;

static bool ok(hetinv_result_t r, const char *what) {
  if (r == HETINV_SUCCESS) return true;
  fprintf(stderr, "hetinv-mpi-equivalence: %s failed: %s (%s)\n", what, hetinv_result_name(r),
          hetinv_context_last_error_message(NULL));
  return false;
}

/* A 4 x 3 x 2 heterogeneous, index-mismatched medium; five pencil beams
 * (so 2 and 4 ranks get unequal blocks of emitters); an orthographic
 * sensor, a time-resolved row and a hemispherical detector. */
static bool compute(hetinv_context_t *ctx, results_t *out) {
  const double lo[3] = {0, 0, 0}, hi[3] = {8, 6, 4};
  hetinv_medium_t *m = NULL;
  hetinv_emitter_t *beam[MAX_EMITTERS] = {0};
  hetinv_sensor_t *ortho = NULL, *hemi = NULL;
  hetinv_pathlength_t *steady = NULL, *bins = NULL;
  hetinv_measurements_t *set = NULL;
  hetinv_param_map_t *map = NULL, *coarse = NULL;
  hetinv_estimator_t *est = NULL;
  bool good = ok(hetinv_medium_create(ctx, lo, hi, (int32_t[]){4, 3, 2}, &m), "medium");
  for (int32_t i = 0; good && i < 24; ++i) {
    good = ok(hetinv_medium_set_voxel(m, i % 4, (i / 4) % 3, i / 12, 0.05 + 0.01 * i,
                                      0.8 + 0.05 * (i % 7), 0.1 * (i % 5) - 0.2),
              "voxel");
  }
  good = good && ok(hetinv_medium_set_ior(m, 1.3, 1.0), "ior") && ok(hetinv_medium_commit(m), "commit");
  for (int e = 0; good && e < emitters; ++e) {
    good = ok(hetinv_emitter_create_ideal(m, (double[]){1.0 + 1.4 * e, 1.0 + e, -1},
                                          (double[]){0, 0, 1}, &beam[e]),
              "emitter");
  }
  good = good &&
         ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MIN, (double[]){0, 0, -1},
                                              (double[]){0, 0}, (double[]){8, 6}, 3, 2, &ortho),
            "ortho") &&
         ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MAX, NULL, NULL, &hemi), "hemi") &&
         ok(hetinv_pathlength_create_steady(ctx, &steady), "steady") &&
         ok(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, 2, (double[]){5, 20}, 10, &bins),
            "bins") &&
         ok(hetinv_measurements_create(ctx, &set), "set");
  for (int e = 0; good && e < emitters; ++e) {
    good = ok(hetinv_measurements_add(set, beam[e], ortho, e == 2 ? bins : steady, NULL), "row") &&
           ok(hetinv_measurements_add(set, beam[e], hemi, steady, NULL), "row");
  }
  size_t n = hetinv_measurements_value_count(set);
  out->count = n;
  double *measured = calloc(n, sizeof(double)), *cot = calloc(n, sizeof(double));
  uint8_t *mask = calloc(n, 1);
  good = good && measured && cot && mask;
  for (size_t i = 0; good && i < n; ++i) {
    measured[i] = 1e-3 * (double)(i % 7);
    cot[i] = (i % 3 == 0) ? 1.0 : -0.5;
    mask[i] = i % 4 != 1;
  }
  good = good && ok(hetinv_measurements_set_values(set, measured, NULL, n), "values") &&
         ok(hetinv_measurements_set_mask(set, mask, n), "mask") &&
         ok(hetinv_param_map_create_identity(m, HETINV_FREE_ALL, &map), "map") &&
         ok(hetinv_param_map_create_coarse(m, (int32_t[]){2, 1, 1}, HETINV_FREE_ALL, &coarse),
            "coarse map") &&
         ok(hetinv_estimator_create(ctx, &est), "estimator") &&
         ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, PHOTONS), "photons") &&
         ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, BATCHES), "batches");
  out->k = hetinv_param_map_size(map);
  out->k_coarse = hetinv_param_map_size(coarse);
  out->values = calloc(n, sizeof(double));
  out->std_errors = calloc(n, sizeof(double));
  out->ballistic = calloc(n, sizeof(double));
  out->rendered = calloc(n, sizeof(double));
  out->grad = calloc(out->k + 1, sizeof(double));
  out->grad_se = calloc(out->k + 1, sizeof(double));
  out->loss_grad = calloc(out->k_coarse + 1, sizeof(double));
  good = good && out->values && out->std_errors && out->ballistic && out->rendered && out->grad &&
         out->grad_se && out->loss_grad;
  hetinv_render_stats_t st = {.size = sizeof st};
  good = good &&
         ok(hetinv_estimator_render(est, m, set, out->values, out->std_errors, out->ballistic, n),
            "render") &&
         ok(hetinv_estimator_get_stats(est, &st), "stats");
  if (good) {
    double *s = out->stats;
    *s++ = (double)st.size;
    *s++ = (double)st.photons;
    *s++ = st.specular;
    *s++ = st.absorbed;
    *s++ = st.absorbed_std_error;
    for (int f = 0; f < 6; ++f) *s++ = st.escaped[f];
    for (int f = 0; f < 6; ++f) *s++ = st.escaped_std_error[f];
    out->stats[16] = st.truncated;
  }
  good = good &&
         ok(hetinv_estimator_gradient(est, m, set, cot, n, map, out->grad, out->grad_se, out->k),
            "gradient") &&
         ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_EPOCH, 3), "epoch") &&
         ok(hetinv_estimator_loss_gradient(est, m, set, coarse, &out->loss, out->rendered,
                                           out->loss_grad, out->k_coarse),
            "loss gradient");
  free(measured);
  free(cot);
  free(mask);
  hetinv_estimator_destroy(&est);
  hetinv_param_map_destroy(&map);
  hetinv_param_map_destroy(&coarse);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_pathlength_destroy(&bins);
  hetinv_sensor_destroy(&ortho);
  hetinv_sensor_destroy(&hemi);
  for (int e = 0; e < emitters; ++e) hetinv_emitter_destroy(&beam[e]);
  hetinv_medium_destroy(&m);
  return good;
}

static void release(results_t *r) {
  free(r->values);
  free(r->std_errors);
  free(r->ballistic);
  free(r->rendered);
  free(r->grad);
  free(r->grad_se);
  free(r->loss_grad);
}

/* Every number, one per line, exactly (%a). */
static void write_results(FILE *f, const results_t *r) {
  for (size_t i = 0; i < r->count; ++i) {
    fprintf(f, "value %zu %a\nstd_error %zu %a\nballistic %zu %a\nrendered %zu %a\n", i,
            r->values[i], i, r->std_errors[i], i, r->ballistic[i], i, r->rendered[i]);
  }
  for (int i = 0; i < 17; ++i) fprintf(f, "stats %d %a\n", i, r->stats[i]);
  for (size_t i = 0; i < r->k; ++i) fprintf(f, "grad %zu %a\ngrad_se %zu %a\n", i, r->grad[i], i, r->grad_se[i]);
  fprintf(f, "loss 0 %a\n", r->loss);
  for (size_t i = 0; i < r->k_coarse; ++i) fprintf(f, "loss_grad %zu %a\n", i, r->loss_grad[i]);
}

/* Bitwise equality; names the first difference. */
static bool same(const results_t *a, const results_t *b, const char *what) {
  struct { const char *name; const double *x, *y; size_t n; } parts[] = {
      {"values", a->values, b->values, a->count},
      {"std_errors", a->std_errors, b->std_errors, a->count},
      {"ballistic", a->ballistic, b->ballistic, a->count},
      {"stats", a->stats, b->stats, 17},
      {"grad", a->grad, b->grad, a->k},
      {"grad_se", a->grad_se, b->grad_se, a->k},
      {"loss", &a->loss, &b->loss, 1},
      {"rendered", a->rendered, b->rendered, a->count},
      {"loss_grad", a->loss_grad, b->loss_grad, a->k_coarse},
  };
  for (size_t p = 0; p < sizeof parts / sizeof parts[0]; ++p) {
    for (size_t i = 0; i < parts[p].n; ++i) {
      if (memcmp(&parts[p].x[i], &parts[p].y[i], sizeof(double)) != 0) {
        fprintf(stderr, "hetinv-mpi-equivalence: %s: %s[%zu] is %a, serially %a\n", what,
                parts[p].name, i, parts[p].x[i], parts[p].y[i]);
        return false;
      }
    }
  }
  return true;
}

static hetinv_context_t *make_context(int32_t threads) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = threads;
  init.seed = 0x5eed;
  hetinv_context_t *ctx = NULL;
  return ok(hetinv_context_create(&init, &ctx), "context") ? ctx : NULL;
}

int main(int argc, char **argv) {
  const char *out_path = NULL;
  for (int i = 1; i < argc; ++i) {
    if (strcmp(argv[i], "--out") == 0 && i + 1 < argc) {
      out_path = argv[++i];
    } else if (strcmp(argv[i], "--emitters") == 0 && i + 1 < argc && atoi(argv[i + 1]) >= 1 &&
               atoi(argv[i + 1]) <= MAX_EMITTERS) {
      emitters = atoi(argv[++i]);
    } else {
      fprintf(stderr, "usage: hetinv-mpi-equivalence [--out FILE] [--emitters 1..5]\n");
      return 2;
    }
  }
  int rank = 0, ranks = 1;
#ifdef HETINV_TEST_MPI
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
#endif
  bool good = true;
  results_t dist = {0}, alone = {0};
  /* Distributed (MPI_COMM_WORLD by default) with 2 threads per rank. */
  hetinv_context_t *ctx = make_context(2);
  good = ctx != NULL;
  if (good && (hetinv_context_rank(ctx) != rank || hetinv_context_rank_count(ctx) != ranks)) {
    fprintf(stderr, "hetinv-mpi-equivalence: the context is rank %d of %d; MPI says %d of %d\n",
            (int)hetinv_context_rank(ctx), (int)hetinv_context_rank_count(ctx), rank, ranks);
    good = false;
  }
  good = good && compute(ctx, &dist);
  /* Alone, with 1 thread: the serial computation. */
  hetinv_context_t *solo = make_context(1);
  good = good && solo != NULL;
#ifdef HETINV_TEST_MPI
  good = good && ok(hetinv_context_set_mpi_comm(solo, MPI_COMM_SELF), "set_mpi_comm");
#endif
  good = good && hetinv_context_rank(solo) == 0 && hetinv_context_rank_count(solo) == 1;
  good = good && compute(solo, &alone);
  char what[64];
  snprintf(what, sizeof what, "rank %d of %d", rank, ranks);
  good = good && same(&dist, &alone, what);
  if (good && rank == 0 && out_path) {
    FILE *f = fopen(out_path, "w");
    good = f != NULL;
    if (good) {
      write_results(f, &dist);
      good = fclose(f) == 0;
    }
    if (!good) fprintf(stderr, "hetinv-mpi-equivalence: cannot write %s\n", out_path);
  }
  if (good) {
    printf("rank %d of %d: %zu values, %zu + %zu gradient entries identical to the serial run; "
           "loss %a\n", rank, ranks, dist.count, dist.k, dist.k_coarse, dist.loss);
  }
  release(&dist);
  release(&alone);
  hetinv_context_destroy(&ctx);
  hetinv_context_destroy(&solo);
#ifdef HETINV_TEST_MPI
  /* Any rank's failure fails the run. */
  int mine = good ? 0 : 1, any = 0;
  MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  good = any == 0;
  MPI_Finalize();
#endif
  return good ? 0 : 1;
}
