/* The six face names of the example programs' JSON, in the order of enum
 * hetinv_face_id, one table for hetinv-render and hetinv-reconstruct. */
#ifndef HETINV_EXAMPLES_FACES_H
#define HETINV_EXAMPLES_FACES_H

/* "x_min", "x_max", "y_min", "y_max", "z_min", "z_max", then NULL. */
extern const char *const face_names[];

#endif
