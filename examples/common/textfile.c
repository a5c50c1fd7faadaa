/* Small text outputs (CSV tables, the run record) written whole or not at
 * all (textfile.h). */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif
#include "textfile.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

FILE *text_file_begin(const char *path, char *tmp, size_t tmp_size) {
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

int text_file_commit(FILE *f, const char *tmp, const char *path) {
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
