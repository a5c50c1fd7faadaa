#define _XOPEN_SOURCE 700
#include "test_support.h"

#include <dirent.h>
#include <ftw.h>
#include <stdlib.h>
#include <unistd.h>

static char tmpdir[512];

const char *ht_tmpdir_create(const char *test_name) {
  const char *base = getenv("TMPDIR");
  snprintf(tmpdir, sizeof tmpdir, "%s/hetinv-%s-XXXXXX", base ? base : "/tmp", test_name);
  if (mkdtemp(tmpdir) == NULL) {
    print_error("cannot create a temporary directory from %s\n", tmpdir);
    fail();
  }
  return tmpdir;
}

static int remove_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw) {
  (void)sb, (void)flag, (void)ftw;
  return remove(path);
}

void ht_tmpdir_remove(void) {
  if (tmpdir[0] != '\0') nftw(tmpdir, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
  tmpdir[0] = '\0';
}

const char *ht_path(const char *name) {
  static char buffers[4][1024];
  static int next;
  char *b = buffers[next++ % 4];
  snprintf(b, sizeof buffers[0], "%s/%s", tmpdir, name);
  return b;
}

void ht_write_file(const char *path, const void *data, size_t size) {
  FILE *f = fopen(path, "wb");
  assert_non_null(f);
  if (size > 0) assert_int_equal(fwrite(data, 1, size, f), size);
  assert_int_equal(fclose(f), 0);
}

int ht_tmpdir_entry_count(void) {
  DIR *d = opendir(tmpdir);
  if (d == NULL) return -1;
  int n = 0;
  for (struct dirent *e; (e = readdir(d)) != NULL;) {
    if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0) ++n;
  }
  closedir(d);
  return n;
}

int ht_context_setup(void **state) {
  hetinv_context_t *ctx = NULL;
  if (hetinv_context_create(NULL, &ctx) != HETINV_SUCCESS) return -1;
  *state = ctx;
  return 0;
}

int ht_context_teardown(void **state) {
  hetinv_context_t *ctx = *state;
  hetinv_context_destroy(&ctx);
  return 0;
}
