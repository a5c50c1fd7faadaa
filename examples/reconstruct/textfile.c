/* Small text outputs (CSV tables) written whole or not at all: into
 * "<path>.tmp", renamed over <path> once complete. */
#include <stdio.h>

#include "recon.h"

FILE *recon_text_begin(const char *path, char *tmp, size_t tmp_size) {
  int n = snprintf(tmp, tmp_size, "%s.tmp", path);
  if (n < 0 || (size_t)n >= tmp_size) return NULL;
  return fopen(tmp, "w");
}

int recon_text_commit(FILE *f, const char *tmp, const char *path) {
  int failed = ferror(f) != 0;
  if (fclose(f) != 0) failed = 1;
  if (!failed && rename(tmp, path) != 0) failed = 1;
  if (failed) remove(tmp);
  return failed ? -1 : 0;
}
