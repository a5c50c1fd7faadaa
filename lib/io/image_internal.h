/* The image's fields and the helpers shared by image.c, the OpenEXR reader
 * and writer and the PNG writer (never installed). */
#ifndef HV_IMAGE_INTERNAL_H
#define HV_IMAGE_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>

#include <openexr.h>

#include "hetinv/io.h"

enum {
  HV_IMAGE_NAME_MAX = 255,    /* bytes of a channel or attribute name (OpenEXR's long-name limit) */
  HV_IMAGE_STRING_MAX = 65535 /* bytes of a string attribute value */
};

/* OpenEXR keeps channels sorted by name; this string-vector attribute holds
 * the names in the image's order so that a read restores it. */
#define HV_EXR_CHANNEL_ORDER "hetinv:channelOrder"

typedef struct hv_image_attribute {
  char *name;
  hetinv_attribute_type_t type;
  char *string;    /* HETINV_ATTRIBUTE_STRING */
  double real;     /* HETINV_ATTRIBUTE_DOUBLE */
  int32_t integer; /* HETINV_ATTRIBUTE_INT */
} hv_image_attribute_t;

struct hetinv_image {
  hetinv_context_t *ctx;
  int32_t width, height, channel_count;
  size_t pixel_count;               /* width·height */
  float *data;                      /* channel c starts at data + c·pixel_count */
  char **channel_names;             /* channel_count owned names, unique */
  hv_image_attribute_t *attributes; /* in the order they were first set */
  int32_t attribute_count, attribute_capacity;
};

/* Allocates a zeroed image with channels "c0", "c1", ...; the caller has
 * checked the dimensions (> 0, width·height·channels·4 fits in size_t). */
hetinv_result_t hv_image_alloc(hetinv_context_t *ctx, int32_t width,
                               int32_t height, int32_t channel_count, hetinv_image_t **out);

/* True if @p name is 1 to 255 bytes of printable ASCII. */
bool hv_image_name_is_valid(const char *name);
/* True for names OpenEXR or libhetinv manage themselves ("channels",
 * "dataWindow", ..., HV_EXR_CHANNEL_ORDER): not usable as attributes. */
bool hv_image_attribute_is_reserved(const char *name);

/* Stores a copy of @p name as the channel's name (no validation: the caller
 * checked it and its uniqueness). Fails only for lack of memory. */
hetinv_result_t hv_image_store_channel_name(hetinv_image_t *image,
                                            int32_t channel, const char *name);
/* Adds or replaces an attribute (no validation of name or value). Fails only
 * for lack of memory. @p string is used for HETINV_ATTRIBUTE_STRING only. */
hetinv_result_t hv_image_store_attribute(hetinv_image_t *image, const char *name,
                                         hetinv_attribute_type_t type, const char *string,
                                         double real, int32_t integer);

/* Names sorted for lookup by binary search. */
typedef struct hv_name_index {
  const char *name; /* borrowed */
  int32_t index;    /* position in the array the index was built from */
} hv_name_index_t;

/* Sorted index of @p count names; NULL for lack of memory. Free with hv_free. */
hv_name_index_t *hv_name_index_build(const hetinv_context_t *ctx, const char *const *names,
                                     int32_t count);
/* Position of @p name in the indexed array, or -1. */
int32_t hv_name_index_find(const hv_name_index_t *index, int32_t count, const char *name);

/* OpenEXR error handler that keeps the first message OpenEXR reports on the
 * calling thread (instead of printing it to stderr). */
void hv_exr_record_error(exr_const_context_t exr, exr_result_t code, const char *message);
/* Forgets the recorded message. */
void hv_exr_clear_error(void);
/* The recorded message, or OpenEXR's default text for @p code if there is none. */
const char *hv_exr_error_message(exr_result_t code);

#endif
