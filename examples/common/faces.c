/* The face-name table (faces.h). */
#include "faces.h"

#include <stddef.h>

const char *const face_names[] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max", NULL};
