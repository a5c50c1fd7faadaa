/* Shared by the OpenEXR harnesses: a private scratch directory, a context,
 * and a bitwise comparison of two images. */
#ifndef HETINV_FUZZ_EXR_SUPPORT_H
#define HETINV_FUZZ_EXR_SUPPORT_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/context.h"
#include "hetinv/io.h"

#define CHECK(cond) \
  do { \
    if (!(cond)) __builtin_trap(); \
  } while (0)

/* The context every run uses (created once). */
hetinv_context_t *fx_context(void);
/* "<scratch dir>/<name>": the directory is made once per process and removed
 * at exit; the result is valid until the next call. */
const char *fx_path(const char *name);
/* Writes @p size bytes to @p path, replacing it. */
void fx_write_file(const char *path, const uint8_t *data, size_t size);
/* Traps unless both images have the same size, channel names in the same
 * order, bit-identical pixels and the same attributes in the same order. */
void fx_check_same(const hetinv_image_t *a, const hetinv_image_t *b);

#endif
