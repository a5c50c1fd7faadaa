/* hetinv-exr-same: test helper. Checks that every OpenEXR file of folder A
 * has a namesake in folder B with the same size, the same channels and
 * bit-identical pixels (attributes, which name the scene, are not
 * compared): two renders that must agree to the bit, e.g. bins with a
 * delta instrument response and bins without one. A and B may be two
 * files instead; --channel NAME compares that channel alone (files
 * without it in A are skipped, and at least one must have it).
 *
 *   usage: hetinv-exr-same [--channel NAME] A B
 */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <hetinv/hetinv.h>

/* 0 if a and b hold the same pixels (in channel `only`, if not NULL), 1
 * after a message if not, -1 if `only` is set and a lacks that channel. */
static int compare(hetinv_context_t *ctx, const char *a, const char *b, const char *only) {
  hetinv_image_t *ia = NULL, *ib = NULL;
  int status = 1;
  int32_t w[2] = {0, 0}, h[2] = {0, 0}, c[2] = {0, 0};
  if (hetinv_image_read_exr(ctx, a, &ia) != HETINV_SUCCESS ||
      hetinv_image_read_exr(ctx, b, &ib) != HETINV_SUCCESS) {
    fprintf(stderr, "hetinv-exr-same: %s\n", hetinv_context_last_error_message(ctx));
    goto done;
  }
  hetinv_image_get_size(ia, &w[0], &h[0], &c[0]);
  hetinv_image_get_size(ib, &w[1], &h[1], &c[1]);
  int32_t ka = -1, kb = -1;
  if (only != NULL && hetinv_image_find_channel(ia, only, &ka) != HETINV_SUCCESS) {
    status = -1;
    goto done;
  }
  if (only != NULL && hetinv_image_find_channel(ib, only, &kb) != HETINV_SUCCESS) {
    fprintf(stderr, "hetinv-exr-same: %s has a channel \"%s\", %s has none\n", a, only, b);
    goto done;
  }
  if (w[0] != w[1] || h[0] != h[1] || (only == NULL && c[0] != c[1])) {
    fprintf(stderr, "hetinv-exr-same: %s is %d x %d x %d channels, %s is %d x %d x %d\n", a,
            (int)w[0], (int)h[0], (int)c[0], b, (int)w[1], (int)h[1], (int)c[1]);
    goto done;
  }
  for (int32_t k = 0; k < c[0]; ++k) {
    if (only != NULL && k != ka) continue;
    int32_t kk = only != NULL ? kb : k;
    if (only == NULL && strcmp(hetinv_image_channel_name(ia, k), hetinv_image_channel_name(ib, k)) != 0) {
      fprintf(stderr, "hetinv-exr-same: %s: channel %d is \"%s\" in one, \"%s\" in the other\n", a,
              (int)k, hetinv_image_channel_name(ia, k), hetinv_image_channel_name(ib, k));
      goto done;
    }
    const float *pa = hetinv_image_channel_data(ia, k), *pb = hetinv_image_channel_data(ib, kk);
    for (size_t i = 0; i < (size_t)w[0] * (size_t)h[0]; ++i) {
      if (memcmp(&pa[i], &pb[i], sizeof pa[i]) != 0) {
        fprintf(stderr, "hetinv-exr-same: %s: channel \"%s\", pixel %zu: %.9g against %.9g in %s\n",
                a, hetinv_image_channel_name(ia, k), i, (double)pa[i], (double)pb[i], b);
        goto done;
      }
    }
  }
  status = 0;
done:
  hetinv_image_destroy(&ia);
  hetinv_image_destroy(&ib);
  return status;
}

int main(int argc, char **argv) {
  const char *only = NULL;
  if (argc == 5 && strcmp(argv[1], "--channel") == 0) {
    only = argv[2];
    argv += 2;
    argc -= 2;
  }
  if (argc != 3) {
    fprintf(stderr, "usage: hetinv-exr-same [--channel NAME] A B\n");
    return 2;
  }
  hetinv_context_t *ctx = NULL;
  if (hetinv_context_create(NULL, &ctx) != HETINV_SUCCESS) return 1;
  struct stat st;
  if (stat(argv[1], &st) == 0 && S_ISREG(st.st_mode)) { /* two files */
    int status = compare(ctx, argv[1], argv[2], only);
    if (status < 0) fprintf(stderr, "hetinv-exr-same: %s has no channel \"%s\"\n", argv[1], only);
    if (status == 0) printf("hetinv-exr-same: the same pixels\n");
    hetinv_context_destroy(&ctx);
    return status != 0;
  }
  DIR *d = opendir(argv[1]);
  if (d == NULL) {
    fprintf(stderr, "hetinv-exr-same: cannot open %s\n", argv[1]);
    hetinv_context_destroy(&ctx);
    return 1;
  }
  int status = 0, files = 0;
  const struct dirent *e;
  while (status == 0 && (e = readdir(d)) != NULL) {
    size_t n = strlen(e->d_name);
    if (n < 4 || strcmp(e->d_name + n - 4, ".exr") != 0) continue;
    char a[4096], b[4096];
    snprintf(a, sizeof a, "%s/%s", argv[1], e->d_name);
    snprintf(b, sizeof b, "%s/%s", argv[2], e->d_name);
    status = compare(ctx, a, b, only);
    if (status < 0) { /* no such channel: not this file's business */
      status = 0;
      continue;
    }
    ++files;
  }
  closedir(d);
  hetinv_context_destroy(&ctx);
  if (status == 0 && files == 0) {
    fprintf(stderr, "hetinv-exr-same: no .exr file%s%s%s in %s\n", only ? " with a channel \"" : "",
            only ? only : "", only ? "\"" : "", argv[1]);
    return 1;
  }
  if (status == 0) printf("hetinv-exr-same: %d files with the same pixels\n", files);
  return status;
}
