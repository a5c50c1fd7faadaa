/* Sensors: what every kind shares. Each kind lives in one file of
 * lib/sensors/ (its create function, its own data, its scoring hooks);
 * transport/sensor_kind.h declares the hooks the photon loop calls. Other
 * folders read a sensor through the accessors below, never a kind's data. */
#ifndef HV_SENSOR_INTERNAL_H
#define HV_SENSOR_INTERNAL_H

#include <math.h>
#include <stdbool.h>

#include "hetinv/sampling.h"
#include "sampling/geometry.h"

struct hv_sensor_kind; /* transport/sensor_kind.h */

struct hetinv_sensor {
  hetinv_context_t *ctx;
  hv_geometry_t geo;
  const struct hv_sensor_kind *kind; /* its hooks, set by its lib/sensors/ file */
  hetinv_face_t face;
  /* A grid of width × height pixels on the face: pixel (0, 0)'s corner in
   * face coordinates and the pixels' extent (one pixel: a rectangle). */
  int32_t width, height;
  double origin[2], pixel_size[2];
  /* Each pixel sees one direction (an image of the face, as a camera's):
   * layer-wise stages may treat its pixels as points (optimize/layerwise.c). */
  bool images;
  void *data; /* the kind's own data, allocated with the sensor */
};

/* A sensor of `kind` on `face` with data_size bytes of zeroed kind data
 * (s->data), for the create function of that kind; the face is checked. */
hetinv_result_t hv_sensor_new(const hetinv_medium_t *medium, const struct hv_sensor_kind *kind,
                              hetinv_face_t face, size_t data_size, hetinv_sensor_t **out);

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

/* Centre of pixel p, on the sensor's face. */
static inline void hv_sensor_pixel_centre(const hetinv_sensor_t *s, int32_t p, double c[3]) {
  int au, av, n = hv_face_axis(s->face);
  hv_face_uv_axes(s->face, &au, &av);
  c[au] = s->origin[0] + ((p % s->width) + 0.5) * s->pixel_size[0];
  c[av] = s->origin[1] + ((p / s->width) + 0.5) * s->pixel_size[1];
  c[n] = hv_face_plane(&s->geo, s->face);
}

#endif
