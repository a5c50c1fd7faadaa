/* Mitsuba .vol grids: parsing and encoding, apart from files so that the
 * fuzzer and the medium reader can reuse them. Layout: see hetinv/io.h. */
#ifndef HV_VOL_FORMAT_H
#define HV_VOL_FORMAT_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/io.h"

enum { HV_VOL_HEADER_SIZE = 48 }; /* "VOL", version, encoding, 3 dims, channels, 6 floats */

/* Validates the header in bytes[0, size) (size may exceed the header) and
 * its agreement with @p file_size, the whole file's length in bytes. Sets
 * *header and *value_count (dims·channels). Messages name @p source (a
 * path, or a description of an in-memory buffer). */
hetinv_result_t hv_vol_parse_header(const hetinv_context_t *ctx,
                                    const char *source, const unsigned char *bytes, size_t size,
                                    uint64_t file_size, hetinv_vol_header_t *header,
                                    size_t *value_count);

/* Decodes @p n little-endian float32 values that start at value index
 * @p first of the file described by @p header, rejecting NaN and infinity
 * with a message naming the voxel and channel. */
hetinv_result_t hv_vol_decode_values(const hetinv_context_t *ctx,
                                     const char *source, const hetinv_vol_header_t *header,
                                     const unsigned char *bytes, size_t first, size_t n,
                                     float *out);

/* Parses a whole .vol file held in memory: the header, then (if @p data is
 * not NULL) every value into @p data, which holds @p capacity floats. */
hetinv_result_t hv_vol_parse(const hetinv_context_t *ctx, const char *source,
                             const unsigned char *bytes, size_t size, hetinv_vol_header_t *header,
                             float *data, size_t capacity);

/* Reads the file at @p path like hv_vol_parse, streaming the values. */
hetinv_result_t hv_vol_read_file(const hetinv_context_t *ctx, const char *path,
                                 hetinv_vol_header_t *header, float *data, size_t capacity);

/* Validates header and data as hetinv_vol_write() documents, then writes
 * the file atomically. */
hetinv_result_t hv_vol_write_file(const hetinv_context_t *ctx, const char *path,
                                  const hetinv_vol_header_t *header, const float *data,
                                  size_t count);

#endif
