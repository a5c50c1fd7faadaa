/* What every sensor kind shares: allocation with the kind's data, and the
 * public size accessors. The kinds are in lib/sensors/. */
#include <stdalign.h>
#include <stddef.h>

#include "core/alloc.h"
#include "core/error.h"
#include "medium/medium_internal.h"
#include "sampling/sensor_internal.h"

HETINV_API void hetinv_sensor_destroy(hetinv_sensor_t **sensor) {
  HV_API_ENTER();
  if (sensor == NULL || *sensor == NULL) return;
  hv_free((*sensor)->ctx, *sensor); /* the kind's data is in the same block */
  *sensor = NULL;
}

hetinv_result_t hv_sensor_new(const hetinv_medium_t *medium, const struct hv_sensor_kind *kind,
                              hetinv_face_t face, size_t data_size, hetinv_sensor_t **out) {
  hetinv_result_t r = hv_check_face(medium->ctx, face);
  if (r != HETINV_SUCCESS) return r;
  /* The kind's data follows the common part, aligned for any type. */
  const size_t align = alignof(max_align_t);
  size_t head = (sizeof(hetinv_sensor_t) + align - 1) / align * align;
  hetinv_sensor_t *s = hv_calloc(medium->ctx, 1, head + data_size);
  if (s == NULL) return HV_FAIL(medium->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate a sensor");
  s->ctx = medium->ctx;
  hv_geometry_of(medium, &s->geo);
  s->kind = kind;
  s->face = face;
  s->data = data_size > 0 ? (char *)s + head : NULL;
  *out = s;
  return HETINV_SUCCESS;
}

HETINV_API int32_t hetinv_sensor_pixel_count(const hetinv_sensor_t *sensor) {
  HV_API_ENTER();
  return sensor ? sensor->width * sensor->height : 0;
}

HETINV_API hetinv_result_t hetinv_sensor_get_size(const hetinv_sensor_t *sensor, int32_t *width,
                                                  int32_t *height) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, sensor);
  if (width) *width = sensor->width;
  if (height) *height = sensor->height;
  return HETINV_SUCCESS;
}
