/* A log of (voxel, length) segments of one path, for gradient scores. */
#ifndef HV_SEGMENT_SINK_H
#define HV_SEGMENT_SINK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "transport/grid.h"

struct hv_segment_sink {
  int64_t *voxel;
  double *length;
  size_t count, capacity;
  bool overflow; /* a segment did not fit: the caller must grow and retrace */
};

#endif
