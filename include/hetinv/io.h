/**
 * @file io.h
 * @brief Files: Mitsuba .vol grids, OpenEXR images, PNG previews.
 *
 * Every writer writes to a temporary file in the destination folder and
 * renames it into place, so an interrupted or failed write never leaves a
 * partial file under the final name. Every reader validates what it reads
 * and fails with HETINV_ERROR_CORRUPT_FILE (or HETINV_ERROR_UNSUPPORTED /
 * HETINV_ERROR_SIZE_OVERFLOW) and a message naming the offending field,
 * never by crashing.
 */
#ifndef HETINV_IO_H
#define HETINV_IO_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/context.h"
#include "hetinv/export.h"
#include "hetinv/medium.h"
#include "hetinv/result.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------------------ */
/** @name Mitsuba binary grid volumes (.vol)
 *
 * Format (little-endian): "VOL", version byte 3, int32 encoding (1 = float32,
 * the only one supported), int32 xres, yres, zres, int32 channels (1 or 3),
 * six float32 bounding box values (xmin, ymin, zmin, xmax, ymax, zmax), then
 * xres·yres·zres·channels float32 values, index
 * ((z·yres + y)·xres + x)·channels + c. Values must be finite.
 * @{ */

/** Header of a .vol file. */
typedef struct hetinv_vol_header {
  int32_t dims[3];    /**< xres, yres, zres, each > 0 */
  int32_t channels;   /**< 1 or 3 */
  double box_min[3];  /**< lower corner of the bounding box (float32 in the file) */
  double box_max[3];  /**< upper corner of the bounding box (float32 in the file) */
} hetinv_vol_header_t;

/**
 * @brief Read and validate the header of a .vol file (dimensions and file
 *        size are checked against each other; values are not read).
 * @param ctx context for error reporting.
 * @param path file to read.
 * @param[out] header receives the header; zeroed on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_IO (cannot
 *         open/read); HETINV_ERROR_CORRUPT_FILE (wrong magic, truncated,
 *         non-positive dimension, bad box); HETINV_ERROR_UNSUPPORTED (version
 *         other than 3, encoding other than float32, channels other than 1
 *         or 3); HETINV_ERROR_SIZE_OVERFLOW. Thread-safe.
 */
HETINV_API hetinv_result_t hetinv_vol_read_header(hetinv_context_t *ctx, const char *path,
                                                  hetinv_vol_header_t *header);

/**
 * @brief Read a .vol file into caller-owned memory.
 * @param ctx context for error reporting.
 * @param path file to read.
 * @param[out] header receives the header; zeroed on failure.
 * @param[out] data receives dims[0]·dims[1]·dims[2]·channels floats in file order.
 * @param capacity number of floats @p data can hold; too small gives
 *        HETINV_ERROR_INVALID_ARGUMENT (read the header first to size it).
 * @return as hetinv_vol_read_header(), plus HETINV_ERROR_CORRUPT_FILE for a
 *         NaN or infinite value (the message names its voxel and channel).
 *         On failure @p data may have been partly written. Thread-safe.
 */
HETINV_API hetinv_result_t hetinv_vol_read(hetinv_context_t *ctx, const char *path,
                                           hetinv_vol_header_t *header, float *data,
                                           size_t capacity);

/**
 * @brief Write a .vol file (atomically: temporary file, then rename).
 * @param ctx context for error reporting.
 * @param path destination; replaced if it exists.
 * @param header dims > 0, channels 1 or 3, finite box with min < max.
 * @param data dims[0]·dims[1]·dims[2]·channels finite floats.
 * @param count number of floats in @p data; must equal that product.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (bad header, wrong count, non-finite
 *         value); HETINV_ERROR_SIZE_OVERFLOW; HETINV_ERROR_IO. Thread-safe.
 */
HETINV_API hetinv_result_t hetinv_vol_write(hetinv_context_t *ctx, const char *path,
                                            const hetinv_vol_header_t *header, const float *data,
                                            size_t count);

/**
 * @brief Set one parameter of every voxel of an uncommitted medium from a
 *        1-channel .vol file with the same dimensions. The file's bounding box
 *        is not compared: the medium's box applies.
 * @param medium uncommitted medium whose grid matches the file.
 * @param param which parameter to set (enum hetinv_param_id).
 * @param path file to read.
 * @return as hetinv_vol_read() and hetinv_medium_set_grid(); a dimension or
 *         channel mismatch is HETINV_ERROR_INVALID_ARGUMENT.
 */
HETINV_API hetinv_result_t hetinv_medium_read_vol(hetinv_medium_t *medium, hetinv_param_t param,
                                                  const char *path);

/**
 * @brief Write one parameter of a medium as a 1-channel .vol file with the
 *        medium's box and grid (values rounded to float32).
 * @param medium any medium, committed or not; only read.
 * @param param which parameter to write (enum hetinv_param_id).
 * @param path destination; replaced atomically if it exists.
 * @return as hetinv_vol_write(); HETINV_ERROR_OUT_OF_RANGE for an unknown @p param.
 */
HETINV_API hetinv_result_t hetinv_medium_write_vol(const hetinv_medium_t *medium,
                                                   hetinv_param_t param, const char *path);
/** @} */

/* ------------------------------------------------------------------------ */
/** @name Images (OpenEXR, PNG)
 *
 * An image is width × height pixels of float32 in any number of named
 * channels, plus named attributes (string, double or int) that make a file
 * describe itself. A transient (pathlength-resolved) stack is one channel
 * per pathlength bin. Pixel (x, y) of channel c is
 * hetinv_image_channel_data(img, c)[y * width + x], row 0 at the top.
 * An image belongs to one thread at a time.
 * @{ */

/** Opaque image handle. */
typedef struct hetinv_image hetinv_image_t;

/** Type of an image attribute: a value of enum hetinv_attribute_type_id. */
typedef int32_t hetinv_attribute_type_t;

/** Attribute types. Pinned values. */
enum hetinv_attribute_type_id {
  HETINV_ATTRIBUTE_STRING = 0, /**< UTF-8 string */
  HETINV_ATTRIBUTE_DOUBLE = 1, /**< 64-bit float (stored as an EXR "double") */
  HETINV_ATTRIBUTE_INT = 2     /**< 32-bit signed integer */
};

/** Colour maps of PNG previews. Pinned values. */
enum hetinv_colormap_id {
  HETINV_COLORMAP_GRAY = 0,   /**< black to white */
  HETINV_COLORMAP_VIRIDIS = 1 /**< perceptually uniform dark blue → green → yellow */
};

/** Most floats (width × height × channels) of an image made by
 *  hetinv_image_create(): 2^28 (1 GiB), room for every value of the
 *  largest measurement set (HETINV_MAX_MEASUREMENT_VALUES) in four channels. */
#define HETINV_MAX_IMAGE_VALUES (INT64_C(1) << 28)

/**
 * @brief Create an image with all pixels 0, channels named "c0", "c1", ...
 *        and no attributes.
 * @param ctx the context; the image must be destroyed before it.
 * @param width pixels per row, > 0.
 * @param height rows, > 0.
 * @param channel_count channels, > 0; width·height·channel_count at most
 *        HETINV_MAX_IMAGE_VALUES floats in all.
 * @param[out] out receives the image; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (also for more than
 *         HETINV_MAX_IMAGE_VALUES floats); HETINV_ERROR_SIZE_OVERFLOW (a
 *         product that overflows size_t); HETINV_ERROR_OUT_OF_MEMORY.
 *         Thread-safe.
 */
HETINV_API hetinv_result_t hetinv_image_create(hetinv_context_t *ctx, int32_t width,
                                               int32_t height, int32_t channel_count,
                                               hetinv_image_t **out);

/** @brief Destroy an image and set @p *image to NULL; NULL is a no-op. */
HETINV_API void hetinv_image_destroy(hetinv_image_t **image);

/**
 * @brief Size of the image. Outputs may be NULL if not wanted.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT if @p image is NULL.
 */
HETINV_API hetinv_result_t hetinv_image_get_size(const hetinv_image_t *image, int32_t *width,
                                                 int32_t *height, int32_t *channel_count);

/**
 * @brief Pixels of one channel, width·height floats, row-major, owned by the
 *        image and valid until it is destroyed. NULL for a NULL image or a
 *        channel out of range.
 */
HETINV_API float *hetinv_image_channel_data(hetinv_image_t *image, int32_t channel);

/**
 * @brief Rename a channel.
 * @param image the image.
 * @param channel index, 0 ≤ channel < channel count.
 * @param name 1 to 255 bytes, printable ASCII, not used by another channel. Copied.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE
 *         (channel); HETINV_ERROR_INVALID_ARGUMENT (bad or duplicate name);
 *         HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_image_set_channel_name(hetinv_image_t *image, int32_t channel,
                                                         const char *name);

/** @brief Name of a channel, owned by the image and valid until that channel is
 *         renamed or the image destroyed; NULL if out of range. */
HETINV_API const char *hetinv_image_channel_name(const hetinv_image_t *image, int32_t channel);

/**
 * @brief Index of the channel called @p name.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE
 *         if there is no such channel (then *channel = -1).
 */
HETINV_API hetinv_result_t hetinv_image_find_channel(const hetinv_image_t *image, const char *name,
                                                     int32_t *channel);

/**
 * @brief Set (add or replace) an attribute.
 * @param image the image.
 * @param value the value (a string is copied).
 * @param name 1 to 255 bytes of printable ASCII, not a reserved name: the
 *        standard OpenEXR header attributes channels, compression,
 *        dataWindow, displayWindow, lineOrder, pixelAspectRatio,
 *        screenWindowCenter, screenWindowWidth, tiles, type, name, version,
 *        chunkCount, maxSamplesPerPixel, and hetinv:channelOrder. Copied.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (bad name; a non-finite double;
 *         a string longer than 65535 bytes); HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_image_set_attribute_string(hetinv_image_t *image,
                                                             const char *name, const char *value);
/** @copydoc hetinv_image_set_attribute_string */
HETINV_API hetinv_result_t hetinv_image_set_attribute_double(hetinv_image_t *image,
                                                             const char *name, double value);
/** @copydoc hetinv_image_set_attribute_string */
HETINV_API hetinv_result_t hetinv_image_set_attribute_int(hetinv_image_t *image, const char *name,
                                                          int32_t value);

/** @brief Number of attributes; 0 for NULL. */
HETINV_API int32_t hetinv_image_attribute_count(const hetinv_image_t *image);

/**
 * @brief Name and type of attribute @p index (0 ≤ index < count), in the
 *        order they were set (or read). Either output may be NULL. The name
 *        is owned by the image and valid until the image is destroyed.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE.
 */
HETINV_API hetinv_result_t hetinv_image_attribute_at(const hetinv_image_t *image, int32_t index,
                                                     const char **name,
                                                     hetinv_attribute_type_t *type);

/**
 * @brief Value of the attribute called @p name. The string is owned by the
 *        image and valid until that attribute is set again (a new value is a
 *        new string) or the image is destroyed.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_OUT_OF_RANGE (no such attribute);
 *         HETINV_ERROR_INVALID_ARGUMENT (it has another type).
 */
HETINV_API hetinv_result_t hetinv_image_get_attribute_string(const hetinv_image_t *image,
                                                             const char *name, const char **value);
/** @copydoc hetinv_image_get_attribute_string */
HETINV_API hetinv_result_t hetinv_image_get_attribute_double(const hetinv_image_t *image,
                                                             const char *name, double *value);
/** @copydoc hetinv_image_get_attribute_string */
HETINV_API hetinv_result_t hetinv_image_get_attribute_int(const hetinv_image_t *image,
                                                          const char *name, int32_t *value);

/**
 * @brief Write the image as a single-part scanline OpenEXR file, float32
 *        channels, ZIP compression (a chunk ZIP does not shrink is stored
 *        uncompressed, as the format requires), with its attributes in the
 *        header.
 *        Atomic (temporary file, then rename). OpenEXR stores channels
 *        sorted by name; when the image's order differs, the string-vector
 *        attribute "hetinv:channelOrder" records it and
 *        hetinv_image_read_exr() restores it.
 * @param image the image; only read.
 * @param path destination; replaced atomically if it exists.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (empty path); HETINV_ERROR_IO;
 *         HETINV_ERROR_UNSUPPORTED (more than 32767 channels, or a 16-row
 *         chunk over 2 GiB); HETINV_ERROR_OUT_OF_MEMORY;
 *         HETINV_ERROR_INTERNAL (an unexpected OpenEXR failure).
 */
HETINV_API hetinv_result_t hetinv_image_write_exr(const hetinv_image_t *image, const char *path);

/**
 * @brief Read a single-part OpenEXR file (scanline or tiled, the first
 *        level of a mipmap; half, float or uint channels, converted to
 *        float) with its string, float, double and int attributes (floats
 *        become doubles). The image is the data window, whose first pixel
 *        is pixel (0, 0); it must equal the display window, since a crop
 *        or overscan would be read shifted. Attributes an image cannot
 *        hold (reserved or malformed names, strings over 65535 bytes,
 *        non-finite numbers, other types) are skipped without error.
 * @param ctx the context; the image must be destroyed before it.
 * @param path file to read.
 * @param[out] out receives the image; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_IO;
 *         HETINV_ERROR_CORRUPT_FILE; HETINV_ERROR_UNSUPPORTED (deep data,
 *         subsampled channels, more than one part, a data window that is
 *         not the display window, DWAA or DWAB compression under an
 *         OpenEXR library older than 3.1.10); HETINV_ERROR_SIZE_OVERFLOW;
 *         HETINV_ERROR_OUT_OF_MEMORY. Thread-safe.
 */
HETINV_API hetinv_result_t hetinv_image_read_exr(hetinv_context_t *ctx, const char *path,
                                                 hetinv_image_t **out);

/**
 * @brief Write one channel as an 8-bit RGB PNG false-colour preview
 *        (atomic). Values map linearly from [lo, hi] onto the colour map and
 *        are clamped; non-finite values are drawn black (gray) or magenta.
 * @param image the image; only read.
 * @param channel index of the channel to draw.
 * @param path destination; replaced atomically if it exists.
 * @param lo the value drawn as the colormap's first colour.
 * @param hi the value drawn as its last; if lo == hi the channel's finite minimum and maximum are used.
 * @param colormap a value of enum hetinv_colormap_id.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE
 *         (channel, colormap); HETINV_ERROR_INVALID_ARGUMENT (non-finite or
 *         lo > hi, empty path); HETINV_ERROR_IO; HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_image_write_png(const hetinv_image_t *image, int32_t channel,
                                                  const char *path, double lo, double hi,
                                                  int32_t colormap);
/** @} */

#ifdef __cplusplus
}
#endif

#endif /* HETINV_IO_H */
