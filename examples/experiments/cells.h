/* One finished cell of an experiment table (an imaging configuration on
 * one volume), kept on disk so a long table is built across sittings: a
 * rerun reads finished cells back instead of recomputing them. */
#ifndef HETINV_EXPERIMENT_CELLS_H
#define HETINV_EXPERIMENT_CELLS_H

#include <stdbool.h>
#include <stddef.h>

#include "recon.h"

typedef struct experiment_cell {
  recon_errors_t errors;
  double seconds;   /* of the run that computed it */
} experiment_cell_t;

/* The text that identifies what a cell computed: every scene field the
 * result depends on. A stored cell counts only if its key is equal. */
void experiment_cell_key(const recon_scene_t *scene, char *key, size_t key_size);

/* Reads <dir>/cell.csv. True if it exists, parses and has this key. */
bool experiment_cell_load(const char *dir, const char *key, experiment_cell_t *cell);

/* Writes <dir>/cell.csv whole or not at all; -1 with errno on failure. */
int experiment_cell_store(const char *dir, const char *key, const experiment_cell_t *cell);

/* A cell's Cramér–Rao bound at its truth (recon_bound_t's summary):
 * what the configuration's data allow, beside what the recovery reached. */
typedef struct experiment_bound {
  double mean[3], median[3], max[3]; /* relative, over the finite bounds */
  double lower_mean[3];              /* mean of sqrt(1/F_kk)/value */
  int32_t positive_definite;         /* 0: mean, median, max are NaN */
  /* Where F̂ is not positive definite: the local bound at
   * recon_bound_t::local_best, mean and max; radius −1 and NaN otherwise. */
  int32_t local_radius;
  double local_mean[3], local_max[3];
  double seconds;
} experiment_bound_t;

/* The data's key (the cell's without the optimizer's settings) and the
 * bound's photons per emitter and replicates. */
void experiment_bound_key(const recon_scene_t *scene, int64_t photons, int32_t replicates, char *key,
                          size_t key_size);

/* <dir>/bound.csv, as experiment_cell_load and experiment_cell_store. */
bool experiment_bound_load(const char *dir, const char *key, experiment_bound_t *bound);
int experiment_bound_store(const char *dir, const char *key, const experiment_bound_t *bound);

/* A bound stored for the same data in another folder `from` (a cell
 * folder of another run): loaded, and its bound.csv, bound.exr and
 * bound_*.png copied into `dir` (each written whole, then renamed), so
 * the cell reads it back from then on. False if `from` holds no bound
 * under this key; -1 with errno on a failed copy. */
int experiment_bound_adopt(const char *dir, const char *from, const char *key, experiment_bound_t *bound);

#endif
