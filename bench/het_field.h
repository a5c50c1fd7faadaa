/* hetinv-bench-forward --write-het-field FILE: A1-het's voxel field for a
 * voxel peer, the σa and σs that hetinv traces for --case a1-het,
 * laid out as mcxyz (Jacques' voxel Monte Carlo, bench/peers_mcxyz.sh)
 * indexes its voxels, so that both codes trace the same medium:
 *   - 2·100³ IEEE-754 doubles, little-endian, no header (16 000 000 bytes):
 *     all σa first, then all σs;
 *   - in cm⁻¹, mcxyz's unit: hetinv's value in mm⁻¹ times 10 (that one
 *     rounding, at most half an ulp, is the only change to the values);
 *   - mcxyz's order: element iz·Ny·Nx + ix·Ny + iy (y fastest, then x, then
 *     depth), where mcxyz's depth axis points into the medium from the lit
 *     face: mcxyz voxel (ix, iy, iz) is hetinv voxel (ix, iy, 99 - iz), i.e.
 *     x' = x - 5 mm, y' = y - 5 mm, z' = 10 mm - z (the beam at x' = y' = 0
 *     on z' = 0, pointing to +z'). A mirror image, which transport with the
 *     Henyey-Greenstein phase function does not see.
 * The file is written beside FILE under a temporary name and renamed onto
 * FILE only once complete: on any failure (no such directory, a FILE that
 * exists but is not a writable regular file, disk full) the message names
 * FILE and the cause, the exit status is 1, and FILE is left as it was.
 * One line on success:
 *   het_field file=FILE voxels=1000000 bytes=16000000 order=mcxyz units=1/cm
 *             sigma_a_mean=M sigma_s_mean=S
 */
#ifndef HETINV_BENCH_HET_FIELD_H
#define HETINV_BENCH_HET_FIELD_H

/* Writes the field to path; 0, or 1 after a message on stderr. */
int het_field_write(const char *path);

#endif
