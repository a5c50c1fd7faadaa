/* hetinv-bench-mpi-scaling: forward and gradient throughput of the
 * distributed estimator at 1 rank and at all the ranks of MPI_COMM_WORLD
 * (MPI build only). Run it under mpirun with one thread per rank:
 *
 *   mpirun -np 2 hetinv-bench-mpi-scaling [--photons N] [--emitters E]
 *          [--repeat R] [--threads T]
 *
 * Scene: the A1-het medium of hetinv-bench-forward (100³ voxels) lit by
 * E pencil beams (default 8) spread over the top face, each scored by the
 * top face's hemispherical detector; N photons per beam (default 20000);
 * gradient: cotangent 1 on every value, identity map over σa, σs and g
 * (3·10⁶ entries), so each rank's gathered partial gradients are large.
 * The 1-rank figures come from rank 0 alone (its context on
 * MPI_COMM_SELF) while the other ranks wait; then every rank runs on
 * MPI_COMM_WORLD. Output, one line per figure:
 *
 *   forward ranks=1 threads=1 photons=P seconds=T paths_per_s=X
 *   forward ranks=2 threads=1 photons=P seconds=T paths_per_s=X ratio_over_1=S
 *   gradient ranks=1 ...
 *   gradient ranks=2 ... ratio_over_1=S
 *   gradient_fixed ranks=1 seconds=T   (2 photons per beam: grid, plans,
 *   gradient_fixed ranks=2 seconds=T    buffers and the gather, no paths)
 *   gradient_overhead ranks=2 seconds=T  (T_2 − T_1 / 2: what distribution
 *                                         costs per call at this size)
 *   identical=yes                      (1 rank and 2 ranks agree bitwise)
 *
 * The fastest of R runs (default 2) is reported. */
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "a1_scene.h"
#include "hetinv/mpi.h"

#define MAX_EMITTERS 64

typedef struct figures {
  double forward_s, gradient_s;
  double value;  /* the first value, to compare */
  double *grad;  /* k entries */
} figures_t;

/* One timed render and one timed gradient with photons per emitter. */
static bool run(scene_t *s, MPI_Comm sync, const hetinv_param_map_t *map, size_t n, double photons,
                double *values, double *cot, figures_t *out, size_t k) {
  bool ok = check(hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_PHOTONS, photons), s->ctx,
                  "set_param PHOTONS");
  MPI_Barrier(sync); /* every rank of the run starts together */
  double t0 = MPI_Wtime();
  ok = ok && check(hetinv_estimator_render(s->est, s->medium, s->set, values, NULL, NULL, n),
                   s->ctx, "render");
  double t1 = MPI_Wtime();
  ok = ok && check(hetinv_estimator_gradient(s->est, s->medium, s->set, cot, n, map, out->grad,
                                             NULL, k),
                   s->ctx, "gradient");
  double t2 = MPI_Wtime();
  out->forward_s = t1 - t0;
  out->gradient_s = t2 - t1;
  out->value = values[0];
  return ok;
}

/* Best of `repeat` runs on the context's current communicator. */
static bool best_of(scene_t *s, MPI_Comm sync, const hetinv_param_map_t *map, size_t n,
                    double photons, double *values, double *cot, figures_t *best, size_t k,
                    int repeat) {
  figures_t f = {.grad = best->grad};
  for (int r = 0; r < repeat; ++r) {
    if (!run(s, sync, map, n, photons, values, cot, &f, k)) return false;
    if (r == 0 || f.forward_s < best->forward_s) best->forward_s = f.forward_s;
    if (r == 0 || f.gradient_s < best->gradient_s) best->gradient_s = f.gradient_s;
    best->value = f.value;
  }
  return true;
}

int main(int argc, char **argv) {
  int provided = 0, rank = 0, ranks = 1;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  double photons = 20000, emitters = 8, repeat = 2, threads = 1;
  bool bad = false;
  for (int i = 1; i < argc && !bad; i += 2) {
    const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
    bad = v == NULL;
    if (!bad && strcmp(a, "--photons") == 0) {
      bad = !parse_number(v, 2, 281474976710655.0, &photons);
    } else if (!bad && strcmp(a, "--emitters") == 0) {
      bad = !parse_number(v, 1, MAX_EMITTERS, &emitters);
    } else if (!bad && strcmp(a, "--repeat") == 0) {
      bad = !parse_number(v, 1, 1000, &repeat);
    } else if (!bad && strcmp(a, "--threads") == 0) {
      bad = !parse_number(v, 1, 256, &threads);
    } else {
      bad = true;
    }
  }
  if (bad) {
    if (rank == 0) {
      fprintf(stderr, "usage: mpirun -np R hetinv-bench-mpi-scaling [--photons N] [--emitters E] "
                      "[--repeat R] [--threads T]\n");
    }
    MPI_Finalize();
    return 2;
  }
  scene_t s;
  hetinv_emitter_t *extra[MAX_EMITTERS] = {0};
  hetinv_param_map_t *map = NULL;
  bool ok = scene_create(CASE_A1_HET, (int32_t)threads, photons, &s);
  /* Beams 1.. on a ring around the first (the centre of the top face). */
  for (int e = 1; ok && e < (int)emitters; ++e) {
    double x = 5.0 + 3.0 * ((e % 3) - 1) + 0.1 * e, y = 5.0 + 3.0 * (((e / 3) % 3) - 1) - 0.1 * e;
    ok = check(hetinv_emitter_create_ideal(s.medium, (double[]){x, y, 10.0},
                                           (double[]){0, 0, -1}, &extra[e]),
               s.ctx, "emitter_create_ideal") &&
         check(hetinv_measurements_add(s.set, extra[e], s.sensor, s.steady, NULL), s.ctx,
               "measurements_add");
  }
  ok = ok && check(hetinv_param_map_create_identity(s.medium, HETINV_FREE_ALL, &map), s.ctx,
                   "param_map_create_identity");
  size_t n = hetinv_measurements_value_count(s.set), k = hetinv_param_map_size(map);
  double *values = calloc(n, sizeof(double)), *cot = calloc(n, sizeof(double));
  figures_t one = {.grad = calloc(k, sizeof(double))}, all = {.grad = calloc(k, sizeof(double))};
  figures_t fixed1 = {.grad = calloc(k, sizeof(double))}, fixed_all = {.grad = calloc(k, sizeof(double))};
  ok = ok && values && cot && one.grad && all.grad && fixed1.grad && fixed_all.grad;
  for (size_t i = 0; ok && i < n; ++i) cot[i] = 1.0;
  /* 1 rank: rank 0 alone; the others wait at the barrier. */
  int good = ok, everyone = 0;
  MPI_Allreduce(&good, &everyone, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  ok = everyone;
  if (ok && rank == 0) {
    ok = check(hetinv_context_set_mpi_comm(s.ctx, MPI_COMM_SELF), s.ctx, "set_mpi_comm SELF") &&
         best_of(&s, MPI_COMM_SELF, map, n, photons, values, cot, &one, k, (int)repeat) &&
         best_of(&s, MPI_COMM_SELF, map, n, 2, values, cot, &fixed1, k, (int)repeat);
  }
  good = ok; /* the other ranks wait here for rank 0 */
  MPI_Allreduce(&good, &everyone, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  ok = everyone;
  /* All ranks. */
  ok = ok && check(hetinv_context_set_mpi_comm(s.ctx, MPI_COMM_WORLD), s.ctx, "set_mpi_comm WORLD") &&
       best_of(&s, MPI_COMM_WORLD, map, n, photons, values, cot, &all, k, (int)repeat) &&
       best_of(&s, MPI_COMM_WORLD, map, n, 2, values, cot, &fixed_all, k, (int)repeat);
  /* Rank 0 holds the 1-rank run; every rank holds the same all-rank run. */
  if (ok && rank == 0) {
    double p = photons * emitters;
    printf("forward ranks=1 threads=%d photons=%.0f seconds=%.3f paths_per_s=%.0f\n", (int)threads,
           p, one.forward_s, p / one.forward_s);
    printf("forward ranks=%d threads=%d photons=%.0f seconds=%.3f paths_per_s=%.0f "
           "ratio_over_1=%.2f\n",
           ranks, (int)threads, p, all.forward_s, p / all.forward_s, one.forward_s / all.forward_s);
    printf("gradient ranks=1 threads=%d photons=%.0f seconds=%.3f paths_per_s=%.0f\n",
           (int)threads, p, one.gradient_s, p / one.gradient_s);
    printf("gradient ranks=%d threads=%d photons=%.0f seconds=%.3f paths_per_s=%.0f "
           "ratio_over_1=%.2f\n",
           ranks, (int)threads, p, all.gradient_s, p / all.gradient_s,
           one.gradient_s / all.gradient_s);
    printf("gradient_fixed ranks=1 seconds=%.4f\n", fixed1.gradient_s);
    printf("gradient_fixed ranks=%d seconds=%.4f\n", ranks, fixed_all.gradient_s);
    printf("gradient_overhead ranks=%d seconds=%.4f\n", ranks,
           all.gradient_s - one.gradient_s / ranks);
    bool same = memcmp(&one.value, &all.value, sizeof(double)) == 0 &&
                memcmp(one.grad, all.grad, k * sizeof(double)) == 0;
    printf("identical=%s\n", same ? "yes" : "no");
  }
  free(values);
  free(cot);
  free(one.grad);
  free(all.grad);
  free(fixed1.grad);
  free(fixed_all.grad);
  hetinv_param_map_destroy(&map);
  if (s.ctx) {
    hetinv_measurements_destroy(&s.set); /* before the emitters its rows name */
    for (int e = 1; e < (int)emitters; ++e) hetinv_emitter_destroy(&extra[e]);
    scene_destroy(&s);
  }
  MPI_Finalize();
  return ok ? 0 : 1;
}
