/* What hetinv-render writes: per orthographic row an OpenEXR stack (one
 * channel per pathlength bin), its standard errors, its ballistic part when
 * there is one, and a PNG preview; totals as text or JSON. */
#ifndef HETINV_RENDER_OUTPUT_H
#define HETINV_RENDER_OUTPUT_H

#include <stdio.h>

#include "scene.h"

typedef struct render_result {
  const double *values;     /* value_count each, as hetinv_estimator_render() gives them */
  const double *std_errors;
  const double *ballistic;
  hetinv_render_stats_t stats;
  int32_t threads;          /* thread count of the context */
  double batches;           /* estimator batches actually set */
  double stream;            /* estimator random stream */
} render_result_t;

/* Writes every orthographic row's files into outdir (which must exist),
 * naming each file on log unless log is NULL. On failure records the
 * reason in jr (naming the file) and returns -1. */
int output_write_images(const scene_t *scene, hetinv_context_t *ctx, const render_result_t *res,
                        const char *outdir, FILE *log, jr_t *jr);

/* Human-readable totals of every row and the render statistics. */
void output_print_summary(const scene_t *scene, const render_result_t *res, FILE *log);

/* The totals as one JSON document (docs/scene-format.md). Returns -1 if out of memory. */
int output_print_totals_json(const scene_t *scene, const render_result_t *res, FILE *out);

#endif
