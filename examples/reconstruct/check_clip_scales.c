/* hetinv-clip-scales-check: test helper. A simulated acquisition with both
 * acquisition.weighting "residual" and estimator.loss_clip_errors
 * "residual" must store, per value, a clip scale sqrt(1 + σ_R²/σ²) with
 * weight 1/(σ² + σ_R²) and standard error σ: so scale·σ·√weight = 1 (to
 * the file's float rounding) wherever σ > 0, and every scale ≥ 1.
 *
 *   usage: hetinv-clip-scales-check MEASUREMENTS_EXR
 *
 * Prints the values checked and the mean scale; exit 0 when the relation
 * holds for each, 1 otherwise (naming the first that fails), 2 on usage. */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>

#include <hetinv/hetinv.h>

int main(int argc, char **argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: hetinv-clip-scales-check MEASUREMENTS_EXR\n");
    return 2;
  }
  hetinv_context_t *ctx = NULL;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS) return 1;
  hetinv_image_t *img = NULL;
  int status = 1;
  int32_t w = 0, h = 0, ch[3] = {-1, -1, -1};
  static const char *const names[3] = {"clip_scale", "std_error", "weight"};
  if (hetinv_image_read_exr(ctx, argv[1], &img) != HETINV_SUCCESS) {
    fprintf(stderr, "hetinv-clip-scales-check: %s\n", hetinv_context_last_error_message(ctx));
    goto done;
  }
  for (int c = 0; c < 3; ++c) {
    if (hetinv_image_find_channel(img, names[c], &ch[c]) != HETINV_SUCCESS) {
      fprintf(stderr, "hetinv-clip-scales-check: %s has no channel \"%s\"\n", argv[1], names[c]);
      goto done;
    }
  }
  hetinv_image_get_size(img, &w, &h, NULL);
  const float *scale = hetinv_image_channel_data(img, ch[0]), *se = hetinv_image_channel_data(img, ch[1]);
  const float *weight = hetinv_image_channel_data(img, ch[2]);
  size_t n = (size_t)w * (size_t)h, checked = 0;
  double sum = 0.0;
  status = 0;
  for (size_t i = 0; i < n && status == 0; ++i) {
    double s = scale[i], e = se[i], wt = weight[i];
    bool ok = s >= 1.0 && (e > 0.0 ? fabs(s * e * sqrt(wt) - 1.0) <= 1e-5 : s == 1.0);
    if (!ok) {
      fprintf(stderr, "hetinv-clip-scales-check: value %zu: clip_scale %.9g, std_error %.9g, weight %.9g; "
                      "expected clip_scale >= 1 and clip_scale * std_error * sqrt(weight) = 1\n", i, s, e, wt);
      status = 1;
    }
    checked += e > 0.0;
    sum += s;
  }
  if (status == 0) printf("%zu values, %zu with a standard error; mean clip scale %.4g\n", n, checked, sum / (double)n);
done:
  hetinv_image_destroy(&img);
  hetinv_context_destroy(&ctx);
  return status;
}
