/* One channel of a measurements EXR, for the test helpers that compare
 * what hetinv-reconstruct stored (hetinv-clip-scales-check,
 * hetinv-snr-mask-check). */
#ifndef HETINV_EXAMPLES_CHECK_CHANNEL_H
#define HETINV_EXAMPLES_CHECK_CHANNEL_H

#include <stddef.h>

#include <hetinv/hetinv.h>

/* The channel `name` of `path` (its n values), reading the file into *img
 * on first use; NULL after a message on stderr prefixed with `prog`. */
const float *check_channel(hetinv_context_t *ctx, const char *prog, const char *path, hetinv_image_t **img,
                           const char *name, size_t *n);

#endif
