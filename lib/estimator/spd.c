/* The diagonal of a symmetric positive definite matrix's inverse (spd.h). */
#include "estimator/spd.h"

#include <math.h>

bool hv_spd_inverse_diagonal(double *A, size_t m, double *scale, double *out) {
  for (size_t i = 0; i < m; ++i) {
    if (!(A[i * m + i] > 0.0)) return false;
    scale[i] = 1.0 / sqrt(A[i * m + i]);
  }
  for (size_t i = 0; i < m; ++i) {
    for (size_t j = 0; j < m; ++j) A[i * m + j] *= scale[i] * scale[j];
  }
  for (size_t j = 0; j < m; ++j) { /* A = L Lᵀ, L in the lower triangle */
    double d = A[j * m + j];
    for (size_t l = 0; l < j; ++l) d -= A[j * m + l] * A[j * m + l];
    if (!(d > 1e-12)) return false;
    double ljj = sqrt(d);
    A[j * m + j] = ljj;
    for (size_t i = j + 1; i < m; ++i) {
      double s = A[i * m + j];
      for (size_t l = 0; l < j; ++l) s -= A[i * m + l] * A[j * m + l];
      A[i * m + j] = s / ljj;
    }
  }
  /* X = L⁻¹ (lower triangular) into the upper triangle's mirror: solve
   * column by column; (A⁻¹)_kk = Σ_i X_ik². */
  for (size_t k = 0; k < m; ++k) out[k] = 0.0;
  double *x = scale + m; /* m scratch doubles */
  for (size_t c = 0; c < m; ++c) {
    for (size_t i = c; i < m; ++i) {
      double s = i == c ? 1.0 : 0.0;
      for (size_t l = c; l < i; ++l) s -= A[i * m + l] * x[l];
      x[i] = s / A[i * m + i];
      out[c] += x[i] * x[i];
    }
  }
  for (size_t k = 0; k < m; ++k) out[k] *= scale[k] * scale[k];
  return true;
}

