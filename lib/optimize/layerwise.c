/* The layer-wise recursive initialisation of the paper's Fig. 2(b): with
 * a source and sensor on the same face, light of pathlength τ cannot have
 * reached deeper than a known depth, so shallow layers can be estimated
 * first from short pathlengths, then the next layer with the earlier ones
 * known, and so on. Each layer becomes a stage that frees its voxels and
 * keeps only the values its light can explain. */
#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "medium/medium_internal.h"
#include "optimize/optimizer_internal.h"
#include "sampling/emitter_internal.h"
#include "sampling/measurements_internal.h"
#include "sampling/pathlength_internal.h"
#include "sampling/sensor_internal.h"

/* A frontlit row: an ideal beam and an imaging sensor (one direction per
 * pixel, as the orthographic one) on the face it enters, resolved in
 * pathlength. */
static bool frontlit(const hv_row_t *row) {
  const hetinv_emitter_t *e = row->emitter;
  const hetinv_sensor_t *s = row->sensor;
  return e->kind == HV_EMITTER_IDEAL && s->images && e->faces[0] == s->face && !row->pathlength->steady;
}

/* Layer of every voxel: depth of its centre below the nearest lit face, in h. */
static void voxel_layers(const hetinv_medium_t *m, const bool lit[6], double h, int32_t *layer) {
  double size[3];
  for (int a = 0; a < 3; ++a) size[a] = (m->box_max[a] - m->box_min[a]) / m->dims[a];
  size_t v = 0;
  for (int32_t z = 0; z < m->dims[2]; ++z) {
    for (int32_t y = 0; y < m->dims[1]; ++y) {
      for (int32_t x = 0; x < m->dims[0]; ++x, ++v) {
        int32_t idx[3] = {x, y, z};
        double depth = (double)INFINITY;
        for (int f = 0; f < 6; ++f) {
          if (!lit[f]) continue;
          int a = hv_face_axis(f);
          double c = m->box_min[a] + (idx[a] + 0.5) * size[a];
          depth = fmin(depth, (f & 1) ? m->box_max[a] - c : c - m->box_min[a]);
        }
        /* Clamped: a tiny h would overflow the conversion (undefined behaviour). */
        double n = floor(depth / h);
        layer[v] = n < (double)INT32_MAX ? (int32_t)n : INT32_MAX;
      }
    }
  }
}

/* Value mask of stage n: frontlit values whose pathlength window ends
 * before the shortest path that reaches depth (n + 1)·h. */
static void stage_value_mask(const hetinv_measurements_t *set, double h, int32_t n, uint8_t *mask) {
  memset(mask, 0, set->value_count);
  double depth2 = 2.0 * (n + 1) * h;
  for (int32_t r = 0; r < set->row_count; ++r) {
    const hv_row_t *row = &set->rows[r];
    if (!frontlit(row)) continue;
    const double *src = row->emitter->points;
    const hetinv_pathlength_t *pl = row->pathlength;
    for (int32_t p = 0; p < row->pixels; ++p) {
      double c[3], d2 = 0.0;
      hv_sensor_pixel_centre(row->sensor, p, c);
      for (int a = 0; a < 3; ++a) d2 += (c[a] - src[a]) * (c[a] - src[a]);
      /* Mirror image of the sensor below the layer: the shortest path in. */
      double shortest = sqrt(d2 + depth2 * depth2);
      for (int32_t i = 0; i < pl->count; ++i) {
        if (pl->sorted[i] + pl->reach + pl->late <= shortest) { /* late: an IRF's early taps */
          mask[row->offset + (size_t)pl->bin_of[i] * (size_t)row->pixels + (size_t)p] = 1;
        }
      }
    }
  }
}

HETINV_API hetinv_result_t hetinv_optimizer_add_layerwise_stages(hetinv_optimizer_t *optimizer,
                                                                 const hetinv_param_map_t *map,
                                                                 double layer_thickness,
                                                                 int32_t layers,
                                                                 int32_t iterations) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, optimizer);
  const hetinv_context_t *ctx = optimizer->ctx;
  HV_CHECK_NULL(ctx, map);
  const hetinv_measurements_t *set = optimizer->set;
  const hetinv_medium_t *m = optimizer->initial;
  if (!(layer_thickness > 0.0) || !isfinite(layer_thickness)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "layer_thickness is %g; it must be > 0", layer_thickness);
  }
  if (layers < 1 || layers > HETINV_MAX_STAGES - optimizer->stage_count) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "layers is %d; it must be >= 1 and, with the %d stages already there, at most "
                   "HETINV_MAX_STAGES (%d)", (int)layers, (int)optimizer->stage_count, HETINV_MAX_STAGES);
  }
  if (iterations < 0) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "iterations is %d; it must be >= 0", (int)iterations);
  }
  int32_t dims[3];
  hetinv_param_map_get_dims(map, dims);
  if (dims[0] != m->dims[0] || dims[1] != m->dims[1] || dims[2] != m->dims[2]) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the map's grid is %d x %d x %d; layer-wise stages need one value per voxel (%d x %d x %d)",
                   (int)dims[0], (int)dims[1], (int)dims[2], (int)m->dims[0], (int)m->dims[1], (int)m->dims[2]);
  }
  bool lit[6] = {false};
  for (int32_t r = 0; r < set->row_count; ++r) {
    if (frontlit(&set->rows[r])) lit[set->rows[r].sensor->face] = true;
  }
  if (!lit[0] && !lit[1] && !lit[2] && !lit[3] && !lit[4] && !lit[5]) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the set has no frontlit pathlength-resolved row (an ideal beam with an "
                   "orthographic sensor on the face it enters, and pathlength bins)");
  }
  size_t k = hetinv_param_map_size(map), v = m->voxel_count;
  int32_t *layer = hv_calloc(ctx, v, sizeof(int32_t));
  uint8_t *frozen = hv_calloc(ctx, k, 1);
  uint8_t *mask = hv_calloc(ctx, set->value_count, 1);
  hetinv_result_t r = HETINV_SUCCESS;
  if (layer == NULL || frozen == NULL || mask == NULL) {
    r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the layer masks");
  }
  int32_t before = optimizer->stage_count;
  if (r == HETINV_SUCCESS) voxel_layers(m, lit, layer_thickness, layer);
  for (int32_t n = 0; r == HETINV_SUCCESS && n < layers; ++n) {
    for (size_t i = 0; i < k; ++i) {
      size_t cell = 0;
      hetinv_param_map_entry(map, i, NULL, &cell);
      frozen[i] = layer[cell] != n;
    }
    stage_value_mask(set, layer_thickness, n, mask);
    hetinv_stage_t stage = {sizeof stage, map, iterations, frozen, mask, 0.0, 0, 0.0, 0.0, 0.0};
    r = hetinv_optimizer_add_stage(optimizer, &stage);
  }
  /* All layers or none. */
  while (r != HETINV_SUCCESS && optimizer->stage_count > before) {
    hv_stage_t *st = &optimizer->stages[--optimizer->stage_count];
    hv_free(ctx, st->frozen);
    hv_free(ctx, st->value_mask);
  }
  hv_free(ctx, layer);
  hv_free(ctx, frozen);
  hv_free(ctx, mask);
  return r;
}
