/* Small text outputs (CSV tables) written whole or not at all, as the
 * library writes its files: into "<path>.hetinv-tmp-XXXXXX" (the pattern
 * outdir.h removes when a killed run left one), renamed over <path> once
 * complete and on disk. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include "recon.h"

FILE *recon_text_begin(const char *path, char *tmp, size_t tmp_size) {
  int n = snprintf(tmp, tmp_size, "%s.hetinv-tmp-XXXXXX", path);
  if (n < 0 || (size_t)n >= tmp_size) {
    errno = ENAMETOOLONG;
    return NULL;
  }
  int fd = mkstemp(tmp);
  if (fd < 0) return NULL;
  fchmod(fd, 0644); /* mkstemp makes 0600; results are meant to be shared */
  FILE *f = fdopen(fd, "w");
  if (f == NULL) {
    int err = errno;
    close(fd);
    remove(tmp);
    errno = err;
  }
  return f;
}

int recon_text_commit(FILE *f, const char *tmp, const char *path) {
  /* ferror: an earlier fprintf failed; its errno may be gone, so EIO. */
  int err = ferror(f) ? EIO : 0;
  if (fflush(f) != 0 || fsync(fileno(f)) != 0) err = errno;
  if (fclose(f) != 0 && err == 0) err = errno;
  if (err == 0 && rename(tmp, path) != 0) err = errno;
  if (err != 0) {
    remove(tmp);
    errno = err;
    return -1;
  }
  return 0;
}
