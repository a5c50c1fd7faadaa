/* The C side of the Python binding's equality test (test_equality.py).
 *
 * Builds the scene the test builds through the binding, renders it, takes a
 * gradient and a loss gradient, runs a few optimizer iterations on a
 * coarse-to-fine schedule, applies the noise model and fills two synthetic
 * volumes, and prints every resulting double as "<key> <index> <%a>", plus
 * "sizeof <struct> <bytes>" for the structs the binding mirrors. The Python
 * test parses the hexadecimal floats exactly and requires its own results
 * to be the same bits. Keep this scene and the one in test_equality.py in
 * step. Usage: c_reference [output file] (default: stdout).
 */
#include <hetinv/hetinv.h>
#include <stdio.h>
#include <stdlib.h>

static FILE *out;

static void check(hetinv_result_t r, const char *what) {
  if (r != HETINV_SUCCESS) {
    fprintf(stderr, "c_reference: %s: %s: %s\n", what, hetinv_result_name(r),
            hetinv_context_last_error_message(NULL));
    exit(1);
  }
}

static void put(const char *key, const double *v, size_t n) {
  for (size_t i = 0; i < n; ++i) fprintf(out, "%s %zu %a\n", key, i, v[i]);
}

static void put_grids(const char *prefix, const hetinv_medium_t *m) {
  static const char *names[3] = {"sigma_a", "sigma_s", "g"};
  char key[64];
  for (int p = 0; p < 3; ++p) {
    snprintf(key, sizeof key, "%s.%s", prefix, names[p]);
    put(key, hetinv_medium_grid(m, p), hetinv_medium_voxel_count(m));
  }
}

int main(int argc, char **argv) {
  out = argc > 1 ? fopen(argv[1], "w") : stdout;
  if (out == NULL) return 1;
  fprintf(out, "sizeof context_init %zu\n", sizeof(hetinv_context_init_t));
  fprintf(out, "sizeof vol_header %zu\n", sizeof(hetinv_vol_header_t));
  fprintf(out, "sizeof render_stats %zu\n", sizeof(hetinv_render_stats_t));
  fprintf(out, "sizeof stage %zu\n", sizeof(hetinv_stage_t));
  fprintf(out, "sizeof progress %zu\n", sizeof(hetinv_progress_t));
  fprintf(out, "sizeof noise_model %zu\n", sizeof(hetinv_noise_model_t));
  fprintf(out, "sizeof mixture_spec %zu\n", sizeof(hetinv_mixture_spec_t));
  fprintf(out, "sizeof smoke_spec %zu\n", sizeof(hetinv_smoke_spec_t));

  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.seed = 7;
  init.thread_count = 2;
  hetinv_context_t *ctx = NULL;
  check(hetinv_context_create(&init, &ctx), "context");

  /* The true medium: a 4 x 4 cross-section with two inclusions. */
  const double lo[3] = {0, 0, 0}, hi[3] = {4, 4, 1};
  const int32_t dims[3] = {4, 4, 1};
  hetinv_medium_t *truth = NULL;
  check(hetinv_medium_create(ctx, lo, hi, dims, &truth), "medium");
  check(hetinv_medium_set_ior(truth, 1.3, 1.0), "ior");
  check(hetinv_medium_fill(truth, 0.1, 5.0, 0.5), "fill");
  check(hetinv_medium_set_voxel(truth, 1, 1, 0, 0.1, 8.0, 0.5), "voxel");
  check(hetinv_medium_set_voxel(truth, 2, 2, 0, 0.2, 3.0, 0.5), "voxel");
  check(hetinv_medium_commit(truth), "commit");

  /* Two beams and a diffuse source; a camera on top, a detector below. */
  hetinv_emitter_t *em[3] = {NULL, NULL, NULL};
  check(hetinv_emitter_create_ideal(truth, (double[]){1, 4.5, 0.5}, (double[]){0, -1, 0}, &em[0]), "beam 0");
  check(hetinv_emitter_create_ideal(truth, (double[]){3, 4.5, 0.5}, (double[]){0, -1, 0}, &em[1]), "beam 1");
  check(hetinv_emitter_create_diffuse(truth, HETINV_FACE_Y_MIN, (double[]){2, 0.5}, &em[2]), "diffuse");
  hetinv_sensor_t *cam = NULL, *below = NULL;
  check(hetinv_sensor_create_orthographic(truth, HETINV_FACE_Y_MAX, (double[]){0, 1, 0},
                                          (double[]){0, 0}, (double[]){1, 1}, 4, 1, &cam), "camera");
  check(hetinv_sensor_create_hemispherical(truth, HETINV_FACE_Y_MIN, NULL, NULL, &below), "detector");
  hetinv_pathlength_t *steady = NULL, *bins = NULL;
  check(hetinv_pathlength_create_steady(ctx, &steady), "steady");
  check(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, 3, (double[]){2, 6, 10}, 4, &bins), "bins");
  hetinv_measurements_t *set = NULL;
  check(hetinv_measurements_create(ctx, &set), "set");
  for (int e = 0; e < 3; ++e) {
    check(hetinv_measurements_add(set, em[e], cam, steady, NULL), "row");
    check(hetinv_measurements_add(set, em[e], below, steady, NULL), "row");
  }
  check(hetinv_measurements_add(set, em[0], cam, bins, NULL), "row");
  size_t n = hetinv_measurements_value_count(set);

  hetinv_estimator_t *est = NULL;
  check(hetinv_estimator_create(ctx, &est), "estimator");
  check(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, 3000), "photons");
  check(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 16), "batches");

  double *values = calloc(n, sizeof *values), *se = calloc(n, sizeof *se);
  double *ballistic = calloc(n, sizeof *ballistic);
  check(hetinv_estimator_render(est, truth, set, values, se, ballistic, n), "render");
  put("render.values", values, n);
  put("render.std_errors", se, n);
  put("render.ballistic", ballistic, n);
  hetinv_render_stats_t stats = {.size = sizeof stats};
  check(hetinv_estimator_get_stats(est, &stats), "stats");
  double photons = (double)stats.photons;
  put("stats.photons", &photons, 1);
  put("stats.specular", &stats.specular, 1);
  put("stats.absorbed", &stats.absorbed, 1);
  put("stats.escaped", stats.escaped, 6);

  /* Noisy measurements. */
  hetinv_noise_model_t noise;
  hetinv_noise_model_default(&noise);
  noise.seed = 11;
  noise.read_noise = 2.0;
  double *noisy = calloc(n, sizeof *noisy), *noisy_se = calloc(n, sizeof *noisy_se), exposure = 0;
  check(hetinv_noise_apply(ctx, &noise, values, noisy, noisy_se, n, &exposure), "noise");
  put("noise.values", noisy, n);
  put("noise.std_errors", noisy_se, n);
  put("noise.exposure", &exposure, 1);
  check(hetinv_measurements_set_values(set, noisy, noisy_se, n), "set values");

  /* Gradient of the sum of the values with respect to every voxel's σs. */
  hetinv_param_map_t *fine = NULL, *coarse = NULL;
  check(hetinv_param_map_create_identity(truth, HETINV_FREE(HETINV_PARAM_SIGMA_S), &fine), "identity");
  check(hetinv_param_map_create_coarse(truth, (int32_t[]){2, 2, 1}, HETINV_FREE(HETINV_PARAM_SIGMA_S), &coarse), "coarse");
  size_t k = hetinv_param_map_size(fine);
  double *ones = calloc(n, sizeof *ones), *grad = calloc(k, sizeof *grad), *grad_se = calloc(k, sizeof *grad_se);
  for (size_t i = 0; i < n; ++i) ones[i] = 1.0;
  check(hetinv_estimator_gradient(est, truth, set, ones, n, fine, grad, grad_se, k), "gradient");
  put("gradient.grad", grad, k);
  put("gradient.std_errors", grad_se, k);

  /* The loss and its gradient at a homogeneous initial guess. */
  hetinv_medium_t *initial = NULL;
  check(hetinv_medium_create(ctx, lo, hi, dims, &initial), "initial");
  check(hetinv_medium_set_ior(initial, 1.3, 1.0), "ior");
  check(hetinv_medium_fill(initial, 0.1, 5.0, 0.5), "fill");
  check(hetinv_medium_commit(initial), "commit");
  double loss = 0, *rendered = calloc(n, sizeof *rendered);
  check(hetinv_estimator_loss_gradient(est, initial, set, fine, &loss, rendered, grad, k), "loss gradient");
  put("loss_gradient.loss", &loss, 1);
  put("loss_gradient.grad", grad, k);
  put("loss_gradient.rendered", rendered, n);

  /* Coarse to fine: 3 iterations on 2 x 2 cells, then 3 per voxel. */
  hetinv_optimizer_t *opt = NULL;
  check(hetinv_optimizer_create(ctx, set, initial, &opt), "optimizer");
  check(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 1.0, 10.0), "bounds");
  check(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_AVERAGE_WINDOW, 2), "window");
  hetinv_stage_t stage = {.size = sizeof stage, .map = coarse, .iterations = 3};
  check(hetinv_optimizer_add_stage(opt, &stage), "stage");
  stage.map = fine;
  check(hetinv_optimizer_add_stage(opt, &stage), "stage");
  check(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, 1000), "photons");
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  check(hetinv_optimizer_run(opt, est, &why), "run");
  double reason = why;
  put("optimizer.reason", &reason, 1);
  size_t iterations = 0;
  const double *losses = hetinv_optimizer_losses(opt, &iterations);
  put("optimizer.losses", losses, iterations);
  check(hetinv_optimizer_get_pi(opt, 1, grad, k), "pi");
  put("optimizer.pi_averaged", grad, k);
  check(hetinv_optimizer_get_pi(opt, 0, grad, k), "pi");
  put("optimizer.pi_last", grad, k);
  hetinv_medium_t *result = NULL;
  check(hetinv_optimizer_result(opt, &result), "result");
  put_grids("optimizer.result", result);

  /* Synthetic volumes on a 5 x 4 x 3 grid. */
  hetinv_medium_t *vol = NULL;
  check(hetinv_medium_create(ctx, lo, (double[]){5, 4, 3}, (int32_t[]){5, 4, 3}, &vol), "volume");
  hetinv_mixture_spec_t mix;
  hetinv_mixture_spec_default(&mix);
  mix.seed = 3;
  mix.constant_axis = 2;
  mix.components = 3;
  check(hetinv_volume_gaussian_mixture(vol, &mix), "mixture");
  put_grids("mixture", vol);
  hetinv_smoke_spec_t smoke;
  hetinv_smoke_spec_default(&smoke);
  smoke.seed = 4;
  smoke.octaves = 2;
  check(hetinv_volume_smoke(vol, &smoke), "smoke");
  put_grids("smoke", vol);

  hetinv_medium_destroy(&vol);
  hetinv_medium_destroy(&result);
  hetinv_optimizer_destroy(&opt);
  hetinv_medium_destroy(&initial);
  hetinv_param_map_destroy(&coarse);
  hetinv_param_map_destroy(&fine);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&bins);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&below);
  hetinv_sensor_destroy(&cam);
  for (int e = 0; e < 3; ++e) hetinv_emitter_destroy(&em[e]);
  hetinv_medium_destroy(&truth);
  hetinv_context_destroy(&ctx);
  free(values);
  free(se);
  free(ballistic);
  free(noisy);
  free(noisy_se);
  free(ones);
  free(grad);
  free(grad_se);
  free(rendered);
  if (out != stdout) fclose(out);
  return 0;
}
