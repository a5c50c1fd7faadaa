/* hetinv-bound-radii-check: test helper. Where the estimated Fisher matrix
 * is not positive definite, bound.exr holds the local bound at each radius
 * computed (bound_local_r<N>_<param>) beside the one in the maps
 * (bound_local_<param>). All come from one F̂, and for nested windows of
 * one positive definite matrix ((F_WW)⁻¹)_kk never decreases as W grows
 * (a Schur complement), so wherever two consecutive radii are both finite
 * the larger radius's bound is at least the smaller's (to the file's float
 * rounding); and bound_local_<param> is bitwise one of the radii, the same
 * one for the three parameters.
 *
 *   usage: hetinv-bound-radii-check DIR/bound.exr
 *
 * Prints the radii, the picked one and the pairs compared; exit 0 when
 * every relation holds, 1 otherwise (naming the first that fails), 2 on
 * usage. */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include <hetinv/hetinv.h>

#define MAX_RADII 16

static const char *const params[3] = {"sigma_a", "sigma_s", "g"};

static const float *channel(hetinv_image_t *img, const char *name) {
  int32_t c = -1;
  return hetinv_image_find_channel(img, name, &c) == HETINV_SUCCESS ? hetinv_image_channel_data(img, c) : NULL;
}

static bool same_bits(const float *a, const float *b, size_t n) { return memcmp(a, b, n * sizeof *a) == 0; }

int main(int argc, char **argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: hetinv-bound-radii-check DIR/bound.exr\n");
    return 2;
  }
  hetinv_context_t *ctx = NULL;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS) return 1;
  hetinv_image_t *img = NULL;
  int status = 1;
  if (hetinv_image_read_exr(ctx, argv[1], &img) != HETINV_SUCCESS) {
    fprintf(stderr, "hetinv-bound-radii-check: %s\n", hetinv_context_last_error_message(ctx));
    goto done;
  }
  int32_t w = 0, h = 0;
  hetinv_image_get_size(img, &w, &h, NULL);
  const size_t n = (size_t)w * (size_t)h;
  int radii = 0, picked = -1;
  size_t compared = 0;
  status = 0;
  for (int p = 0; p < 3 && status == 0; ++p) {
    char name[64];
    snprintf(name, sizeof name, "bound_local_%s", params[p]);
    const float *best = channel(img, name);
    const float *r_at[MAX_RADII] = {NULL};
    int count = 0;
    for (; count < MAX_RADII; ++count) {
      snprintf(name, sizeof name, "bound_local_r%d_%s", count, params[p]);
      if ((r_at[count] = channel(img, name)) == NULL) break;
    }
    if (best == NULL || count == 0 || (p > 0 && count != radii)) {
      fprintf(stderr, "hetinv-bound-radii-check: %s: %s, %d radii for %s (%d before)\n", argv[1],
              best ? "has bound_local" : "no bound_local", count, params[p], radii);
      status = 1;
      break;
    }
    radii = count;
    int which = -1;
    for (int r = 0; r < count && which < 0; ++r) which = same_bits(best, r_at[r], n) ? r : -1;
    if (which < 0 || (picked >= 0 && which != picked)) {
      fprintf(stderr, "hetinv-bound-radii-check: bound_local_%s is radius %d's (the others' %d)\n", params[p], which,
              picked);
      status = 1;
      break;
    }
    picked = which;
    for (int r = 0; r + 1 < count && status == 0; ++r) {
      for (size_t i = 0; i < n; ++i) {
        double a = (double)r_at[r][i], b = (double)r_at[r + 1][i];
        if (!isfinite(a) || !isfinite(b)) continue;
        ++compared;
        if (b < a * (1.0 - 1e-6)) {
          fprintf(stderr, "hetinv-bound-radii-check: %s pixel %zu: radius %d gives %.9g, radius %d %.9g (smaller)\n",
                  params[p], i, r + 1, b, r, a);
          status = 1;
          break;
        }
      }
    }
  }
  if (status == 0) printf("%d radii, radius %d in the maps; %zu pairs of consecutive radii, none lower\n", radii, picked,
                          compared);
done:
  hetinv_image_destroy(&img);
  hetinv_context_destroy(&ctx);
  return status;
}
