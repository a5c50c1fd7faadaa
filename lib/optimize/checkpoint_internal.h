/* The checkpoint format, shared by its writer (checkpoint.c) and its
 * reader (checkpoint_read.c); the layout is described in checkpoint.c. */
#ifndef HV_CHECKPOINT_INTERNAL_H
#define HV_CHECKPOINT_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "core/hash.h"
#include "optimize/optimizer_internal.h"

#define HV_CKPT_MAGIC "HVCKPT01"
#define HV_CKPT_BYTE_ORDER_TAG UINT64_C(0x0102030405060708)
/* Format 7 added the set's geometry hash and the gain mode at the
 * fingerprint's end: formats up to 6 are read without those two checks
 * (they cannot be made), as before. Format 6 added HETINV_OPTIMIZER_BOX_MARGIN to the fingerprint's
 * tunables, format 5 HETINV_OPTIMIZER_MULTISCALE, format 4
 * HETINV_OPTIMIZER_SMOOTHNESS, format 3 HETINV_ESTIMATOR_LOSS_CLIP to its
 * estimator tunables. Formats 2 to 5 are still read: the tunables they
 * lack were 0 (iterates inside the box, no multi-scale step, no prior,
 * least squares) in every such run. */
#define HV_CKPT_FORMAT_VERSION 7u
#define HV_CKPT_FORMAT_OLDEST 2u

/* The configuration a checkpoint was written for; stored as it is (every
 * field 8 bytes, no padding). */
typedef struct hv_ckpt_fingerprint {
  uint64_t value_count, rows, emitters, stages;
  uint64_t stage_k[64], stage_iterations[64], stage_masks[64]; /* first 64 stages */
  double param[HETINV_OPTIMIZER_PARAM_COUNT_];
  double lo[HETINV_PARAM_COUNT], hi[HETINV_PARAM_COUNT];
  double est_param[HETINV_ESTIMATOR_PARAM_COUNT_];
  uint64_t set_hash, medium_hash, seed;
  /* Format 7: hv_set_geometry_hash() of the set, and the estimator's gain
   * mode (compared when the run continues, as the estimator's tunables). */
  uint64_t geometry_hash, gain_mode;
} hv_ckpt_fingerprint_t;

/* The fingerprint of an optimizer (its stages' iterations resolved). */
void hv_ckpt_fingerprint(const hetinv_optimizer_t *opt, hv_ckpt_fingerprint_t *f);

/* Names the first difference between two fingerprints (in msg, or a
 * constant string), or returns NULL. */
const char *hv_ckpt_fingerprint_diff(const hv_ckpt_fingerprint_t *a, const hv_ckpt_fingerprint_t *b,
                                     char *msg, size_t len);

/* Restores the checkpoint held in data[0 .. len) into an optimizer whose
 * run has not started and whose stages are added, validating every field
 * against the optimizer's configuration; `name` names the data in
 * messages (e.g. "'run.ckpt'"). On failure the optimizer is left as it
 * was. hetinv_optimizer_resume() reads the file and calls this; the
 * checkpoint fuzzer calls it directly. */
hetinv_result_t hv_checkpoint_restore(hetinv_optimizer_t *opt, const unsigned char *data, size_t len,
                                      const char *name);

#endif
