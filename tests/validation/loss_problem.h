/* The small loss problem shared by test_gradient_loss.c and
 * measure_gradient_gain.c: a 2 × 1 × 1 medium, one oblique beam, three
 * hemispherical sensors and one pixel, measured values that are the
 * medium's own (stream 60000) scaled, per-value weights and a mask that
 * leaves the last value out. */
#ifndef HETINV_TEST_LOSS_PROBLEM_H
#define HETINV_TEST_LOSS_PROBLEM_H

#include <stdint.h>

#include "validation.h"

#define LOSS_K 6      /* σa, σs, g of both voxels */
#define LOSS_VALUES 4 /* one per row */
#define LOSS_STREAMS 64     /* M for each factor of the reference */
#define LOSS_REF_PHOTONS 1e6 /* photons per FD render (all streams), and for Ī(π) */

extern const double loss_weight[LOSS_VALUES];
extern const uint8_t loss_mask[LOSS_VALUES];

typedef struct loss_problem {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_emitter_t *beam;
  hetinv_sensor_t *top, *bottom, *side, *pixel;
  hetinv_pathlength_t *steady;
  hetinv_measurements_t *set;
  hetinv_param_map_t *map;
} loss_problem_t;

void loss_problem_build(loss_problem_t *p, uint64_t seed);
void loss_problem_destroy(loss_problem_t *p);

/* Sets the measured values (returned in measured), weights and mask. */
void loss_problem_set_measured(loss_problem_t *p, double measured[LOSS_VALUES]);

/* The two factors of the reference gradient: per stream j, D^(j)_{n,k}
 * (central differences on common random numbers) and, from stream
 * LOSS_STREAMS + j, C^(j)_n = I_n(π). Returns the photons of each render. */
double loss_problem_reference(const loss_problem_t *p, double D[LOSS_STREAMS][LOSS_VALUES][LOSS_K],
                              double C[LOSS_STREAMS][LOSS_VALUES]);

#endif
