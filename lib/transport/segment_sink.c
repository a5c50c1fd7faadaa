#include "transport/segment_sink.h"

void hv_segment_sink_add(hv_segment_sink_t *sink, int64_t voxel, double length) {
  if (sink->count == sink->capacity) {
    sink->overflow = true;
    return;
  }
  sink->voxel[sink->count] = voxel;
  sink->length[sink->count] = length;
  sink->count++;
}
