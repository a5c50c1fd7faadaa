/* The box a medium fills and its interface: what emitters, sensors and
 * measurement sets copy from a medium, and the face arithmetic they share. */
#ifndef HV_GEOMETRY_H
#define HV_GEOMETRY_H

#include <stdbool.h>
#include <string.h>

#include "hetinv/medium.h"
#include "hetinv/sampling.h"

typedef struct hv_geometry {
  double lo[3], hi[3];
  double eta, eta_out;
} hv_geometry_t;

void hv_geometry_of(const hetinv_medium_t *medium, hv_geometry_t *out);

/* The first of the box's six coordinates and two indices in which a and b
 * differ ("box_max[z]", "eta (outside)"), with a's and b's values; NULL
 * if none. Messages print the pair with %.17g: boxes read from float32
 * files differ from typed ones past %g's six digits. */
const char *hv_geometry_first_difference(const hv_geometry_t *a, const hv_geometry_t *b, double *va, double *vb);

static inline bool hv_geometry_equal(const hv_geometry_t *a, const hv_geometry_t *b) {
  for (int i = 0; i < 3; ++i) {
    if (a->lo[i] != b->lo[i] || a->hi[i] != b->hi[i]) return false; /* -0 == +0 */
  }
  return a->eta == b->eta && a->eta_out == b->eta_out;
}

/* Face f lies at coordinate hv_face_plane() on axis f/2; its outward normal
 * is -1 (f even) or +1 (f odd) along that axis. */
static inline int hv_face_axis(hetinv_face_t f) { return f >> 1; }
static inline double hv_face_sign(hetinv_face_t f) { return (f & 1) ? 1.0 : -1.0; }
static inline double hv_face_plane(const hv_geometry_t *g, hetinv_face_t f) {
  return (f & 1) ? g->hi[f >> 1] : g->lo[f >> 1];
}
/* The two in-face axes (u, v): the other axes in increasing order. */
static inline void hv_face_uv_axes(hetinv_face_t f, int *u, int *v) {
  int a = f >> 1;
  *u = a == 0 ? 1 : 0;
  *v = a == 2 ? 1 : 2;
}
static inline void hv_face_normal(hetinv_face_t f, double n[3]) {
  n[0] = n[1] = n[2] = 0.0;
  n[f >> 1] = hv_face_sign(f);
}

/* Checks a face id; fails with a message otherwise. */
hetinv_result_t hv_check_face(const hetinv_context_t *ctx, hetinv_face_t face);

/* Normalises a finite non-zero 3-vector named @p what; fails with a message otherwise. */
hetinv_result_t hv_normalize3(const hetinv_context_t *ctx, const char *what,
                              const double in[3], double out[3]);

/* Entry of the ray o + t·d (t ≥ 0) into the box: the smallest t at which it
 * is inside, the face it enters through, or false if it misses (or only
 * touches an edge). The origin must not be strictly inside. */
bool hv_ray_enter_box(const hv_geometry_t *g, const double o[3], const double d[3], double *t,
                      hetinv_face_t *face);

#endif
