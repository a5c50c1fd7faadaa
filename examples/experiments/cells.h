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

/* Room for a key: the longest, every option away from its default, is
 * about 2 kB. */
#define EXPERIMENT_KEY_SIZE 4096

/* The text that identifies what a cell computed: every scene field the
 * result depends on. A stored cell counts only if its key is equal. False
 * if the key did not fit key_size (it is never compared cut short). */
bool experiment_cell_key(const recon_scene_t *scene, char *key, size_t key_size);

/* Reads <dir>/cell.csv: 1 if it holds a cell under this key, 0 if it is
 * missing or holds another key's, -1 with a message naming the file and
 * line in why if it holds this key but cannot be read whole (damaged:
 * a figure that is not a finite number >= 0, text after it, a line cut
 * short), which a run reports instead of silently recomputing. */
int experiment_cell_load(const char *dir, const char *key, experiment_cell_t *cell, char *why, size_t why_size);

/* Writes <dir>/cell.csv whole or not at all; -1 with errno on failure. */
int experiment_cell_store(const char *dir, const char *key, const experiment_cell_t *cell);

/* Removes <dir>/<record> (cell.csv, bound.csv) before the files it
 * describes are computed again under another key, so that a run stopped
 * or failing half-way cannot leave an old record beside new files (which
 * a later run under the old settings would take as that cell's). 0 if
 * removed or absent; -1 with a message naming the file in why. */
int experiment_record_drop(const char *dir, const char *record, char *why, size_t why_size);

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
 * bound's photons per emitter and replicates; false if it did not fit. */
bool experiment_bound_key(const recon_scene_t *scene, int64_t photons, int32_t replicates, char *key,
                          size_t key_size);

/* <dir>/bound.csv, as experiment_cell_load (figures may be NaN) and
 * experiment_cell_store. */
int experiment_bound_load(const char *dir, const char *key, experiment_bound_t *bound, char *why, size_t why_size);
int experiment_bound_store(const char *dir, const char *key, const experiment_bound_t *bound);

/* A bound stored for the same data in another folder `from` (a cell
 * folder of another run): loaded, and its bound.csv, bound.exr and
 * bound_*.png copied into `dir` (each written whole, then renamed), so
 * the cell reads it back from then on: 1. 0 if `from` holds no bound
 * under this key; -1 with a message in why if its bound is damaged or a
 * copy failed. */
int experiment_bound_adopt(const char *dir, const char *from, const char *key, experiment_bound_t *bound, char *why,
                           size_t why_size);

#endif
