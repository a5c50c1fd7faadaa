/* The calibration gain of the loss (gain.c). */
#ifndef HV_GAIN_H
#define HV_GAIN_H

#include "estimator/pass.h"

/* With est->gain_mode != HETINV_GAIN_NONE: fits the gains to the rendered
 * values (one per plan of `pass`, or one) and their standard errors (the
 * denominator's I² less their square; NULL: I² as it is), stores them in
 * est, and fills cot[n] = 2·mask·w·k·(k·I_n − Ī_n) and
 * *loss = Σ mask·w·(k·I_n − Ī_n)², or Huber's terms and k times their
 * clipped slopes under HETINV_ESTIMATOR_LOSS_CLIP (loss_term.h). */
hetinv_result_t hv_gain_fit(hetinv_estimator_t *est, const hv_pass_t *pass,
                            const hetinv_measurements_t *set, const double *values,
                            const double *std_errors, double *cot, double *loss);

#endif
