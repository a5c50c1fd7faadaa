/* A1-het's voxel field for a voxel peer (het_field.h). */
#include "het_field.h"

#include <errno.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "a1_scene.h"

/* Writes n doubles little-endian; false on a short write (errno set). */
static bool write_le_doubles(FILE *f, const double *v, size_t n) {
  unsigned char buf[8 * 512];
  size_t used = 0;
  for (size_t i = 0; i < n; ++i) {
    uint64_t bits;
    memcpy(&bits, &v[i], sizeof bits);
    for (int b = 0; b < 8; ++b) buf[used++] = (unsigned char)(bits >> (8 * b));
    if (used == sizeof buf || i + 1 == n) {
      if (fwrite(buf, 1, used, f) != used) return false;
      used = 0;
    }
  }
  return true;
}

/* Through a temporary file renamed onto path. */
int het_field_write(const char *path) {
  static const char *const me = "hetinv-bench-forward: --write-het-field";
  /* An existing FILE must be a regular file that we may write: rename
   * would replace a device, a link or a read-only file regardless. */
  struct stat st;
  if (lstat(path, &st) == 0) {
    if (!S_ISREG(st.st_mode)) {
      fprintf(stderr, "%s %s: %s\n", me, path,
              S_ISDIR(st.st_mode)   ? "is a directory"
              : S_ISLNK(st.st_mode) ? "is a symbolic link (give its target)"
                                    : "exists and is not a regular file");
      return 1;
    }
    if (access(path, W_OK) != 0) {
      fprintf(stderr, "%s %s: not writable: %s\n", me, path, strerror(errno));
      return 1;
    }
  } else if (errno != ENOENT) {
    fprintf(stderr, "%s %s: %s\n", me, path, strerror(errno));
    return 1;
  }
  scene_t s;
  if (!scene_create(CASE_A1_HET, 1, 1.0, &s)) return 1;
  int32_t dims[3];
  const double *sa = hetinv_medium_grid(s.medium, HETINV_PARAM_SIGMA_A);
  const double *ss = hetinv_medium_grid(s.medium, HETINV_PARAM_SIGMA_S);
  if (!check(hetinv_medium_get_dims(s.medium, dims), s.ctx, "get_dims") || !sa || !ss) {
    scene_destroy(&s);
    return 1;
  }
  const size_t nx = (size_t)dims[0], ny = (size_t)dims[1], nz = (size_t)dims[2];
  const size_t n = nx * ny * nz;
  double *out = malloc(2 * n * sizeof *out);
  if (!out) {
    fprintf(stderr, "%s %s: out of memory\n", me, path);
    scene_destroy(&s);
    return 1;
  }
  /* mcxyz (ix, iy, iz) at iz·ny·nx + ix·ny + iy is hetinv (ix, iy, nz-1-iz)
   * at ix + nx·(iy + ny·(nz-1-iz)); 10 × mm⁻¹ = cm⁻¹. */
  double sum_a = 0.0, sum_s = 0.0;
  for (size_t iz = 0; iz < nz; ++iz) {
    for (size_t ix = 0; ix < nx; ++ix) {
      for (size_t iy = 0; iy < ny; ++iy) {
        size_t m = iz * ny * nx + ix * ny + iy, h = ix + nx * (iy + ny * (nz - 1 - iz));
        out[m] = 10.0 * sa[h];
        out[n + m] = 10.0 * ss[h];
        sum_a += out[m];
        sum_s += out[n + m];
      }
    }
  }
  scene_destroy(&s);

  size_t len = strlen(path);
  char *tmp = malloc(len + sizeof ".tmp.XXXXXX");
  if (!tmp) {
    fprintf(stderr, "%s %s: out of memory\n", me, path);
    free(out);
    return 1;
  }
  memcpy(tmp, path, len);
  memcpy(tmp + len, ".tmp.XXXXXX", sizeof ".tmp.XXXXXX");
  int fd = mkstemp(tmp);
  if (fd < 0) {
    fprintf(stderr, "%s %s: cannot create a file there: %s\n", me, path, strerror(errno));
    free(tmp);
    free(out);
    return 1;
  }
  mode_t mask = umask(0);
  umask(mask);
  (void)fchmod(fd, (mode_t)(0666 & ~mask)); /* mkstemp's 0600 would outlive the rename */
  FILE *f = fdopen(fd, "wb");
  const char *failed = NULL;
  int err = 0;
  if (!f) {
    failed = "cannot open";
    err = errno;
    close(fd);
  } else {
    if (!write_le_doubles(f, out, 2 * n)) {
      failed = "write failed";
      err = errno;
    }
    if (fclose(f) != 0 && !failed) {
      failed = "write failed";
      err = errno;
    }
  }
  if (!failed && rename(tmp, path) != 0) {
    failed = "cannot rename the complete file onto it";
    err = errno;
  }
  if (failed) {
    fprintf(stderr, "%s %s: %s: %s\n", me, path, failed, strerror(err));
    remove(tmp);
  } else {
    printf("het_field file=%s voxels=%zu bytes=%zu order=mcxyz units=1/cm sigma_a_mean=%.6f "
           "sigma_s_mean=%.6f\n",
           path, n, 2 * n * sizeof(double), sum_a / (double)n, sum_s / (double)n);
  }
  free(tmp);
  free(out);
  return failed ? 1 : 0;
}
