/* The diagonal of a symmetric positive definite matrix's inverse: what
 * the Cramér–Rao bounds (fisher.c, crb_local.c) take of F⁻¹. */
#ifndef HV_SPD_H
#define HV_SPD_H

#include <stdbool.h>
#include <stddef.h>

/* diag(A⁻¹) of the symmetric m×m matrix A (row-major, overwritten) into
 * out, through its Cholesky factor after scaling to a unit diagonal;
 * scratch: 2m doubles. False if A is not positive definite (a pivot below
 * 1e-12 of the unit diagonal). */
bool hv_spd_inverse_diagonal(double *A, size_t m, double *scratch, double *out);

#endif
