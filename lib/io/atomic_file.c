#include "io/atomic_file.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/alloc.h"
#include "core/error.h"

static void release(hv_atomic_file_t *f) {
  hv_free(f->ctx, f->tmp_path);
  f->tmp_path = NULL;
  f->fp = NULL;
}

hetinv_result_t hv_atomic_open(const hetinv_context_t *ctx, const char *path,
                               int want_stream, hv_atomic_file_t *f) {
  /* A name no other program writes: the example programs remove leftovers
   * of exactly this pattern from their output folders (examples/common/outdir.h). */
  static const char suffix[] = ".hetinv-tmp-XXXXXX";
  *f = (hv_atomic_file_t){.ctx = ctx, .path = path};
  size_t n = strlen(path);
  if (n == 0) return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "the path is empty");
  f->tmp_path = hv_alloc(ctx, n + sizeof suffix);
  if (f->tmp_path == NULL) {
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate a temporary path");
  }
  memcpy(f->tmp_path, path, n);
  memcpy(f->tmp_path + n, suffix, sizeof suffix);
  int fd = mkstemp(f->tmp_path);
  if (fd < 0) {
    int err = errno;
    release(f);
    return HV_FAIL(ctx, HETINV_ERROR_IO, "cannot create a temporary file beside '%s': %s",
                   path, strerror(err));
  }
  fchmod(fd, 0644); /* mkstemp makes 0600; results are meant to be shared */
  if (!want_stream) {
    close(fd);
    return HETINV_SUCCESS;
  }
  f->fp = fdopen(fd, "wb");
  if (f->fp == NULL) {
    int err = errno;
    close(fd);
    hv_atomic_abort(f);
    return HV_FAIL(ctx, HETINV_ERROR_IO, "cannot open a temporary file beside '%s': %s",
                   path, strerror(err));
  }
  return HETINV_SUCCESS;
}

hetinv_result_t hv_atomic_commit(hv_atomic_file_t *f) {
  if (f->fp != NULL) {
    int bad = ferror(f->fp) || fflush(f->fp) != 0 || fsync(fileno(f->fp)) != 0;
    int err = errno;
    bad |= fclose(f->fp) != 0;
    f->fp = NULL;
    if (bad) {
      hv_atomic_abort(f);
      return HV_FAIL(f->ctx, HETINV_ERROR_IO, "cannot write '%s': %s", f->path,
                     strerror(err ? err : EIO));
    }
  }
  if (rename(f->tmp_path, f->path) != 0) {
    int err = errno;
    hv_atomic_abort(f);
    return HV_FAIL(f->ctx, HETINV_ERROR_IO, "cannot rename the temporary file to '%s': %s",
                   f->path, strerror(err));
  }
  release(f);
  return HETINV_SUCCESS;
}

void hv_atomic_abort(hv_atomic_file_t *f) {
  if (f->fp != NULL) fclose(f->fp);
  if (f->tmp_path != NULL) remove(f->tmp_path);
  release(f);
}
