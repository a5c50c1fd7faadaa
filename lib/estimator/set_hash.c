/* A measurement set hashed. Its geometry: the forward model it is rendered
 * under (the box and interface, and per row its emitter, sensor and
 * pathlength bins with every number that shapes the rendered values), so
 * that a resume under another geometry is refused (the measured values
 * alone may match); and its values. Optimizer checkpoints store both, and
 * the ranks of a collective call compare them. The numbers hashed are the
 * objects' normalised arguments (entry points, weights, bin centres), so a
 * version that derived them otherwise would refuse older checkpoints as
 * another geometry: such a change needs a new checkpoint format. Here, not
 * in lib/sampling, because a sensor's kind is named, and hashes its own
 * arguments, by its hooks (transport/sensor_kind.h). */
#include <string.h>

#include "core/hash.h"
#include "estimator/set_hash.h"
#include "sampling/emitter_internal.h"
#include "sampling/measurements_internal.h"
#include "sampling/pathlength_internal.h"
#include "sampling/sensor_internal.h"
#include "transport/sensor_kind.h"

#define HASH(h, x) hv_fnv1a((h), &(x), sizeof(x))
/* Arrays may be NULL for a kind that has none: then nothing is hashed. */
#define HASH_ARRAY(h, p, n) ((p) ? hv_fnv1a((h), (p), (size_t)(n) * sizeof *(p)) : (h))

static uint64_t hash_geometry(uint64_t h, const hv_geometry_t *g) {
  h = HASH(h, g->lo);
  h = HASH(h, g->hi);
  h = HASH(h, g->eta);
  return HASH(h, g->eta_out);
}

static uint64_t hash_emitter(uint64_t h, const hetinv_emitter_t *e) {
  int32_t kind = (int32_t)e->kind;
  h = HASH(h, kind);
  h = HASH(h, e->power);
  h = HASH(h, e->count);
  h = HASH_ARRAY(h, e->points, 3 * e->count);
  h = HASH_ARRAY(h, e->faces, e->count);
  h = HASH_ARRAY(h, e->directions, 3 * e->count);
  h = HASH_ARRAY(h, e->cdf, e->count);
  h = HASH(h, e->face);
  h = HASH(h, e->direction);
  h = HASH(h, e->rect_min);
  h = HASH(h, e->rect_max);
  h = HASH(h, e->pattern_width);
  return HASH(h, e->pattern_height);
}

/* The kind's name, what every sensor has, and what the kind's hook adds
 * (what the sensor was made from, not its derived record, whose layout a
 * later version may change). */
static uint64_t hash_sensor(uint64_t h, const hetinv_sensor_t *s) {
  h = hv_fnv1a(h, s->kind->name, strlen(s->kind->name) + 1);
  h = HASH(h, s->face);
  h = HASH(h, s->width);
  h = HASH(h, s->height);
  h = HASH(h, s->origin);
  h = HASH(h, s->pixel_size);
  return s->kind->fingerprint ? s->kind->fingerprint(s, h) : h;
}

static uint64_t hash_pathlength(uint64_t h, const hetinv_pathlength_t *p) {
  uint8_t steady = p->steady;
  h = HASH(h, steady);
  h = HASH(h, p->window);
  h = HASH(h, p->count);
  h = HASH(h, p->width);
  h = HASH_ARRAY(h, p->sorted, p->count);
  h = HASH_ARRAY(h, p->bin_of, p->count);
  h = HASH(h, p->taps);
  h = HASH_ARRAY(h, p->tap_offset, p->taps);
  return HASH_ARRAY(h, p->tap_weight, p->taps);
}

uint64_t hv_set_values_hash(const hetinv_measurements_t *set) {
  uint64_t h = HV_FNV_OFFSET;
  size_t n = set->value_count;
  h = hv_fnv1a(h, set->values, n * sizeof(double));
  h = hv_fnv1a(h, set->weights, n * sizeof(double));
  h = hv_fnv1a(h, set->mask, n);
  /* The clip's scales join the hash only where one differs from 1, so a
   * set without them hashes as before they existed (checkpoints store it). */
  for (size_t i = 0; i < n; ++i) {
    if (set->clip_below[i] == 1.0 && set->clip_above[i] == 1.0) continue;
    uint64_t at = i;
    h = hv_fnv1a(h, &at, sizeof at);
    h = hv_fnv1a(h, &set->clip_below[i], sizeof(double));
    h = hv_fnv1a(h, &set->clip_above[i], sizeof(double));
  }
  return h;
}

uint64_t hv_set_geometry_hash(const hetinv_measurements_t *set) {
  uint64_t h = hash_geometry(HV_FNV_OFFSET, &set->geo);
  for (int32_t i = 0; i < set->row_count; ++i) {
    const hv_row_t *row = &set->rows[i];
    h = hash_emitter(h, row->emitter);
    h = hash_sensor(h, row->sensor);
    h = hash_pathlength(h, row->pathlength);
  }
  return h;
}
