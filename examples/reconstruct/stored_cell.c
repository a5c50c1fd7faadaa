/* A finished cell brought back for a check (stored_cell.h). */
#include "stored_cell.h"

#include <stdio.h>

int stored_cell_open(const recon_scene_t *sc, int64_t threads, stored_cell_t *cell, char *msg, size_t msg_size) {
  *cell = (stored_cell_t){0};
  msg[0] = '\0';
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.seed = sc->seed;
  init.thread_count = threads >= 0 ? (int32_t)threads : sc->threads;
  if (hetinv_context_create(&init, &cell->ctx) != HETINV_SUCCESS) {
    snprintf(msg, msg_size, "%s: cannot create a context: %s", sc->name, hetinv_context_last_error_message(NULL));
    return -1;
  }
  hetinv_result_t r = recon_truth_create(cell->ctx, sc, &cell->truth);
  if (r == HETINV_SUCCESS) r = recon_imaging_build(cell->ctx, cell->truth, sc, &cell->im);
  if (r == HETINV_SUCCESS) r = recon_simulate(cell->ctx, sc, cell->truth, &cell->im);
  if (r == HETINV_SUCCESS) r = recon_read_recovery(cell->ctx, sc, &cell->recovery, msg, msg_size);
  if (r == HETINV_SUCCESS) return 0;
  if (msg[0] == '\0') snprintf(msg, msg_size, "%s: %s", sc->name, hetinv_context_last_error_message(cell->ctx));
  stored_cell_close(cell);
  return -1;
}

void stored_cell_close(stored_cell_t *cell) {
  hetinv_medium_destroy(&cell->recovery);
  hetinv_medium_destroy(&cell->truth);
  recon_imaging_release(&cell->im);
  hetinv_context_destroy(&cell->ctx);
}
