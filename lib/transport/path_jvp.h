/* Tangent (forward) mode of the score log: Jacobian–vector products J·v.
 *
 * A splat of contribution c into value n adds c·(S·v) to (J·v)_n, S being
 * the path's score accumulated before the splat — exactly the entries the
 * gradient pass (tracer.h, hv_grad_apply_log) attributes to that splat:
 * the path's entries logged so far, and for a next-event connection also
 * its own segments and the vertex's phase toward the sensor. Each entry's
 * score is dotted with the T tangents once, the first time a splat follows
 * it, and kept in running sums, so the cost stays linear in the path. */
#ifndef HV_PATH_JVP_H
#define HV_PATH_JVP_H

#include <stddef.h>
#include <stdint.h>

#include "transport/grid.h"
#include "transport/path_log.h"

typedef struct hv_jvp_state {
  const hv_grid_t *grid;
  /* T tangents in voxel space: entry (parameter p, voxel k) of tangent t
   * at tangent[(p·voxels + k)·T + t], p = σa, σs, g. */
  const double *tangent;
  int32_t tangents; /* T; 0: not tangent mode */
  size_t voxels;
  /* Optional sparse copy of `tangent` (sparse_start NULL: use the dense
   * one): row r = p·voxels + k holds its nonzero entries t =
   * sparse_index[i] with values sparse_value[i] for i in [sparse_start[r],
   * sparse_start[r + 1]). One-hot tangents (the Fisher matrix's K of them)
   * have one nonzero per row, so a voxel crossing costs O(1) instead of
   * O(T). */
  const size_t *sparse_start;
  const int32_t *sparse_index;
  const double *sparse_value;
  double *run; /* 2T running sums: the path's, then the current connection's */
  size_t path_done, chain_done;       /* entries of each log already summed */
  hv_ray_t path_end, chain_end;       /* voxel ending the last RAY entry summed (k < 0: none) */
} hv_jvp_state_t;

/* A new path: its running sums are zero. */
void hv_jvp_path_begin(hv_jvp_state_t *st);

/* A new connection chain from a vertex in voxel `vertex` whose phase
 * toward the chain's first direction has log-derivative dlog_dg. */
void hv_jvp_chain_begin(hv_jvp_state_t *st, int64_t vertex, double dlog_dg);

/* A splat of `value` at pathlength tau under pathlength function pl:
 * adds value·W_τ(bin)·(S·v_t) to dst[bin·stride + t]. `chain` is the
 * connection's log when the splat ends one (NULL for a path's own exit). */
void hv_jvp_splat(hv_jvp_state_t *st, const hv_path_log_t *path, const hv_path_log_t *chain,
                  const hetinv_pathlength_t *pl, double tau, double value, double *dst,
                  size_t stride);

#endif
