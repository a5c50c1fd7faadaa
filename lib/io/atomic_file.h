/* Atomic file replacement: write a temporary file beside the destination,
 * then rename it over the destination only once it is complete. */
#ifndef HV_ATOMIC_FILE_H
#define HV_ATOMIC_FILE_H

#include <stdio.h>

#include "hetinv/context.h"
#include "hetinv/result.h"

typedef struct hv_atomic_file {
  const hetinv_context_t *ctx;
  const char *path;  /* destination (borrowed) */
  char *tmp_path;    /* "<path>.hetinv-tmp-XXXXXX", created empty */
  FILE *fp;          /* open for writing, or NULL when a library writes tmp_path itself */
} hv_atomic_file_t;

/* Creates the temporary file. With want_stream, f->fp is open on it ("wb");
 * otherwise the file exists, closed, for another library to overwrite.
 * On failure nothing is left on disk and a message is recorded. */
hetinv_result_t hv_atomic_open(const hetinv_context_t *ctx, const char *path,
                               int want_stream, hv_atomic_file_t *f);

/* Flushes and closes f->fp (if any), then renames the temporary file to the
 * destination. On failure the temporary file is removed. Always releases f. */
hetinv_result_t hv_atomic_commit(hv_atomic_file_t *f);

/* Closes and removes the temporary file; releases f. Safe on a released f. */
void hv_atomic_abort(hv_atomic_file_t *f);

#endif
