/* A finished cell brought back for a check: its context, its truth, its
 * data simulated again as the cell did, and its stored recovery. */
#ifndef HETINV_RECON_STORED_CELL_H
#define HETINV_RECON_STORED_CELL_H

#include <stddef.h>
#include <stdint.h>

#include "recon.h"

typedef struct stored_cell {
  hetinv_context_t *ctx;
  hetinv_medium_t *truth, *recovery;
  recon_imaging_t im; /* im.set: the data */
} stored_cell_t;

/* Opens the scene's cell on `threads` threads (-1: the scene's): 0, or -1
 * with "<what or file>: <reason>" in msg and nothing left to close. */
int stored_cell_open(const recon_scene_t *scene, int64_t threads, stored_cell_t *cell, char *msg, size_t msg_size);

void stored_cell_close(stored_cell_t *cell);

#endif
