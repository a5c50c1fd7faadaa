#include "sampling/geometry.h"

#include <math.h>

#include "core/error.h"
#include "medium/medium_internal.h"

void hv_geometry_of(const hetinv_medium_t *medium, hv_geometry_t *out) {
  memcpy(out->lo, medium->box_min, sizeof out->lo);
  memcpy(out->hi, medium->box_max, sizeof out->hi);
  out->eta = medium->eta;
  out->eta_out = medium->eta_out;
}

const char *hv_geometry_first_difference(const hv_geometry_t *a, const hv_geometry_t *b, double *va, double *vb) {
  static const char *const names[8] = {"box_min[x]", "box_min[y]", "box_min[z]", "box_max[x]",
                                       "box_max[y]", "box_max[z]", "eta (inside)", "eta (outside)"};
  const double av[8] = {a->lo[0], a->lo[1], a->lo[2], a->hi[0], a->hi[1], a->hi[2], a->eta, a->eta_out};
  const double bv[8] = {b->lo[0], b->lo[1], b->lo[2], b->hi[0], b->hi[1], b->hi[2], b->eta, b->eta_out};
  for (int i = 0; i < 8; ++i) {
    if (av[i] != bv[i]) {
      *va = av[i];
      *vb = bv[i];
      return names[i];
    }
  }
  return NULL;
}

hetinv_result_t hv_check_face(const hetinv_context_t *ctx, hetinv_face_t face) {
  if (face >= HETINV_FACE_X_MIN && face <= HETINV_FACE_Z_MAX) return HETINV_SUCCESS;
  return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_RANGE,
                 "face is %d; it must be one of HETINV_FACE_X_MIN (0) .. HETINV_FACE_Z_MAX (5)",
                 (int)face);
}

hetinv_result_t hv_normalize3(const hetinv_context_t *ctx, const char *what,
                              const double in[3], double out[3]) {
  /* Scaled by the largest component first, so that no length over- or underflows. */
  double m = fmax(fabs(in[0]), fmax(fabs(in[1]), fabs(in[2])));
  if (!isfinite(in[0]) || !isfinite(in[1]) || !isfinite(in[2]) || !(m > 0.0)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "%s is (%g, %g, %g); it must be finite and not zero", what, in[0], in[1],
                   in[2]);
  }
  double v[3] = {in[0] / m, in[1] / m, in[2] / m};
  double s = 1.0 / sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  for (int i = 0; i < 3; ++i) out[i] = v[i] * s;
  return HETINV_SUCCESS;
}

bool hv_ray_enter_box(const hv_geometry_t *g, const double o[3], const double d[3], double *t,
                      hetinv_face_t *face) {
  double t_in = 0.0, t_out = HUGE_VAL;
  int axis_in = -1;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.0) { /* parallel to these faces: must run strictly between them */
      if (!(o[a] > g->lo[a] && o[a] < g->hi[a])) return false;
      continue;
    }
    double t0 = (g->lo[a] - o[a]) / d[a], t1 = (g->hi[a] - o[a]) / d[a];
    if (t0 > t1) {
      double s = t0;
      t0 = t1;
      t1 = s;
    }
    if (t0 >= t_in) {
      t_in = t0;
      axis_in = a;
    }
    if (t1 < t_out) t_out = t1;
  }
  /* A positive-length chord is needed: touching an edge or a face from
   * outside does not let light in. */
  if (axis_in < 0 || !(t_out > t_in)) return false;
  *t = t_in;
  *face = (hetinv_face_t)(2 * axis_in + (d[axis_in] < 0.0 ? 1 : 0));
  return true;
}
