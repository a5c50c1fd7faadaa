/* Sensors: what the photon loop needs to score light. */
#ifndef HV_SENSOR_INTERNAL_H
#define HV_SENSOR_INTERNAL_H

#include <math.h>
#include <stdbool.h>

#include "hetinv/sampling.h"
#include "sampling/geometry.h"

typedef enum hv_sensor_kind {
  HV_SENSOR_ORTHOGRAPHIC,
  HV_SENSOR_HEMISPHERICAL,
} hv_sensor_kind_t;

struct hetinv_sensor {
  hetinv_context_t *ctx;
  hv_geometry_t geo;
  hv_sensor_kind_t kind;
  hetinv_face_t face;
  int32_t width, height;
  double origin[2];        /* orthographic: pixel (0,0) corner; hemispherical: rect min */
  double pixel_size[2];    /* orthographic: pixel extent; hemispherical: rect extent */
  double dir_out[3];       /* orthographic: direction of the light leaving toward the sensor */
  double dir_in[3];        /* ... its direction inside, before refraction */
  /* Orthographic: radiance per unit of "source strength × transmittance"
   * reaching the face along dir_in: Fresnel transmittance times
   * (η_out/η)², over the projected-area factor |cos| and the pixel area. */
  double connection_scale;
  double ballistic_scale;  /* 1 / pixel area */
};

/* Pixel index of the face point p (on the sensor's face), or -1 if outside
 * every pixel (or the hemispherical rectangle). */
static inline int32_t hv_sensor_pixel_at(const hetinv_sensor_t *s, const double p[3]) {
  int au, av;
  hv_face_uv_axes(s->face, &au, &av);
  double fu = (p[au] - s->origin[0]) / s->pixel_size[0];
  double fv = (p[av] - s->origin[1]) / s->pixel_size[1];
  /* Pixels are half-open, but light leaving exactly through the face's far
   * edge belongs to the pixel that ends there. */
  if (fu == s->width && p[au] >= s->geo.hi[au]) fu = s->width - 0.5;
  if (fv == s->height && p[av] >= s->geo.hi[av]) fv = s->height - 0.5;
  if (!(fu >= 0.0 && fv >= 0.0 && fu < s->width && fv < s->height)) return -1;
  return (int32_t)fv * s->width + (int32_t)fu;
}

#endif
