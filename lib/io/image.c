#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "io/image_internal.h"

/* ---- names ------------------------------------------------------------- */

bool hv_image_name_is_valid(const char *name) {
  size_t n = 0;
  for (; name[n] != '\0'; ++n) {
    if (n >= HV_IMAGE_NAME_MAX || name[n] < 0x20 || name[n] > 0x7e) return false;
  }
  return n > 0;
}

/* Records why @p name (a channel or attribute name) is invalid. */
static hetinv_result_t fail_name(const hetinv_context_t *ctx, const char *what, const char *name) {
  size_t n = strlen(name);
  if (n == 0) return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "the %s is empty", what);
  if (n > HV_IMAGE_NAME_MAX) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the %s is %zu bytes long; at most %d are allowed", what, n,
                   HV_IMAGE_NAME_MAX);
  }
  size_t i = 0;
  while (name[i] >= 0x20 && name[i] <= 0x7e) ++i;
  return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                 "the %s has byte 0x%02X at offset %zu; names must be printable ASCII", what,
                 (unsigned)(unsigned char)name[i], i);
}

bool hv_image_attribute_is_reserved(const char *name) {
  /* Attributes OpenEXR writes itself or that describe the file's structure. */
  static const char *const reserved[] = {
      "channels",          "compression", "dataWindow", "displayWindow",
      "lineOrder",         "pixelAspectRatio", "screenWindowCenter", "screenWindowWidth",
      "tiles",             "type",        "name",       "version",
      "chunkCount",        "maxSamplesPerPixel", HV_EXR_CHANNEL_ORDER};
  for (size_t i = 0; i < sizeof reserved / sizeof reserved[0]; ++i) {
    if (strcmp(name, reserved[i]) == 0) return true;
  }
  return false;
}

/* ---- lookup by name ------------------------------------------------------ */

static int compare_entries(const void *a, const void *b) {
  const hv_name_index_t *x = a, *y = b;
  int c = strcmp(x->name, y->name);
  return c != 0 ? c : (x->index > y->index) - (x->index < y->index);
}

hv_name_index_t *hv_name_index_build(const hetinv_context_t *ctx, const char *const *names,
                                     int32_t count) {
  hv_name_index_t *index = hv_calloc(ctx, (size_t)count, sizeof *index);
  if (index == NULL) return NULL;
  for (int32_t i = 0; i < count; ++i) index[i] = (hv_name_index_t){names[i], i};
  qsort(index, (size_t)count, sizeof *index, compare_entries);
  return index;
}

int32_t hv_name_index_find(const hv_name_index_t *index, int32_t count, const char *name) {
  int32_t lo = 0, hi = count; /* first entry >= name in [lo, hi) */
  while (lo < hi) {
    int32_t mid = lo + (hi - lo) / 2;
    if (strcmp(index[mid].name, name) < 0) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return lo < count && strcmp(index[lo].name, name) == 0 ? index[lo].index : -1;
}

/* ---- life cycle ---------------------------------------------------------- */

static void free_attribute(const hetinv_context_t *ctx, hv_image_attribute_t *a) {
  hv_free(ctx, a->name);
  hv_free(ctx, a->string);
}

HETINV_API void hetinv_image_destroy(hetinv_image_t **image) {
  HV_API_ENTER();
  if (image == NULL || *image == NULL) return;
  hetinv_image_t *img = *image;
  const hetinv_context_t *ctx = img->ctx;
  if (img->channel_names != NULL) {
    for (int32_t c = 0; c < img->channel_count; ++c) hv_free(ctx, img->channel_names[c]);
  }
  for (int32_t i = 0; i < img->attribute_count; ++i) free_attribute(ctx, &img->attributes[i]);
  hv_free(ctx, img->attributes);
  hv_free(ctx, img->channel_names);
  hv_free(ctx, img->data);
  hv_free(ctx, img);
  *image = NULL;
}

hetinv_result_t hv_image_alloc(hetinv_context_t *ctx, int32_t width,
                               int32_t height, int32_t channel_count, hetinv_image_t **out) {
  hetinv_image_t *img = hv_calloc(ctx, 1, sizeof *img);
  if (img == NULL) return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate an image");
  img->ctx = ctx;
  img->width = width;
  img->height = height;
  img->channel_count = channel_count;
  img->pixel_count = (size_t)width * (size_t)height;
  img->data = hv_calloc(ctx, img->pixel_count * (size_t)channel_count, sizeof(float));
  img->channel_names = hv_calloc(ctx, (size_t)channel_count, sizeof(char *));
  bool ok = img->data != NULL && img->channel_names != NULL;
  for (int32_t c = 0; ok && c < channel_count; ++c) {
    char name[16];
    snprintf(name, sizeof name, "c%d", (int)c);
    img->channel_names[c] = hv_strdup(ctx, name);
    ok = img->channel_names[c] != NULL;
  }
  if (!ok) {
    hetinv_image_destroy(&img);
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY,
                   "cannot allocate a %d x %d image of %d channels", (int)width, (int)height,
                   (int)channel_count);
  }
  *out = img;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_image_create(hetinv_context_t *ctx, int32_t width,
                                               int32_t height, int32_t channel_count,
                                               hetinv_image_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(ctx, out);
  *out = NULL;
  HV_CHECK_NULL(ctx, ctx);
  const struct {
    const char *what;
    int32_t value;
  } dims[3] = {{"width", width}, {"height", height}, {"channel_count", channel_count}};
  for (int i = 0; i < 3; ++i) {
    if (dims[i].value <= 0) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "%s is %d; it must be > 0", dims[i].what,
                     (int)dims[i].value);
    }
  }
  size_t floats, bytes;
  if (!hv_mul_size((size_t)width, (size_t)height, &floats) ||
      !hv_mul_size(floats, (size_t)channel_count, &floats) ||
      !hv_mul_size(floats, sizeof(float), &bytes)) {
    return HV_FAIL(ctx, HETINV_ERROR_SIZE_OVERFLOW,
                   "%d x %d pixels of %d channels of float overflow size_t", (int)width,
                   (int)height, (int)channel_count);
  }
  if (floats > (size_t)HETINV_MAX_IMAGE_VALUES) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "%d x %d pixels of %d channels are %zu floats; at most HETINV_MAX_IMAGE_VALUES (%lld)",
                   (int)width, (int)height, (int)channel_count, floats,
                   (long long)HETINV_MAX_IMAGE_VALUES);
  }
  return hv_image_alloc(ctx, width, height, channel_count, out);
}

/* ---- size and channels --------------------------------------------------- */

HETINV_API hetinv_result_t hetinv_image_get_size(const hetinv_image_t *image, int32_t *width,
                                                 int32_t *height, int32_t *channel_count) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, image);
  if (width != NULL) *width = image->width;
  if (height != NULL) *height = image->height;
  if (channel_count != NULL) *channel_count = image->channel_count;
  return HETINV_SUCCESS;
}

HETINV_API float *hetinv_image_channel_data(hetinv_image_t *image, int32_t channel) {
  HV_API_ENTER();
  if (image == NULL || channel < 0 || channel >= image->channel_count) return NULL;
  return image->data + (size_t)channel * image->pixel_count;
}

HETINV_API const char *hetinv_image_channel_name(const hetinv_image_t *image, int32_t channel) {
  HV_API_ENTER();
  if (image == NULL || channel < 0 || channel >= image->channel_count) return NULL;
  return image->channel_names[channel];
}

static int32_t find_channel(const hetinv_image_t *image, const char *name) {
  for (int32_t c = 0; c < image->channel_count; ++c) {
    if (strcmp(image->channel_names[c], name) == 0) return c;
  }
  return -1;
}

hetinv_result_t hv_image_store_channel_name(hetinv_image_t *image,
                                            int32_t channel, const char *name) {
  char *copy = hv_strdup(image->ctx, name);
  if (copy == NULL) {
    return HV_FAIL(image->ctx, HETINV_ERROR_OUT_OF_MEMORY,
                   "cannot allocate the name of channel %d", (int)channel);
  }
  hv_free(image->ctx, image->channel_names[channel]);
  image->channel_names[channel] = copy;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_image_set_channel_name(hetinv_image_t *image, int32_t channel,
                                                         const char *name) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, image);
  HV_CHECK_NULL(image->ctx, name);
  if (channel < 0 || channel >= image->channel_count) {
    return HV_FAIL(image->ctx, HETINV_ERROR_OUT_OF_RANGE,
                   "channel is %d; the image has %d channels (0 to %d)", (int)channel,
                   (int)image->channel_count, (int)image->channel_count - 1);
  }
  if (!hv_image_name_is_valid(name)) return fail_name(image->ctx, "channel name", name);
  int32_t other = find_channel(image, name);
  if (other == channel) return HETINV_SUCCESS;
  if (other >= 0) {
    return HV_FAIL(image->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "channel name \"%s\" is already used by channel %d", name, (int)other);
  }
  return hv_image_store_channel_name(image, channel, name);
}

HETINV_API hetinv_result_t hetinv_image_find_channel(const hetinv_image_t *image, const char *name,
                                                     int32_t *channel) {
  HV_API_ENTER();
  if (channel != NULL) *channel = -1;
  HV_CHECK_NULL(NULL, image);
  HV_CHECK_NULL(image->ctx, name);
  HV_CHECK_NULL(image->ctx, channel);
  *channel = find_channel(image, name);
  if (*channel < 0) {
    return HV_FAIL(image->ctx, HETINV_ERROR_OUT_OF_RANGE, "no channel is called \"%s\"", name);
  }
  return HETINV_SUCCESS;
}

/* ---- attributes ---------------------------------------------------------- */

static int32_t find_attribute(const hetinv_image_t *image, const char *name) {
  for (int32_t i = 0; i < image->attribute_count; ++i) {
    if (strcmp(image->attributes[i].name, name) == 0) return i;
  }
  return -1;
}

hetinv_result_t hv_image_store_attribute(hetinv_image_t *image, const char *name,
                                         hetinv_attribute_type_t type, const char *string,
                                         double real, int32_t integer) {
  const hetinv_context_t *ctx = image->ctx;
  hv_image_attribute_t value = {.type = type, .real = real, .integer = integer};
  if (type == HETINV_ATTRIBUTE_STRING) {
    value.string = hv_strdup(ctx, string);
    if (value.string == NULL) {
      return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY,
                     "cannot allocate the value of attribute \"%s\"", name);
    }
  }
  int32_t i = find_attribute(image, name);
  if (i >= 0) { /* replace in place: the attribute keeps its position */
    value.name = image->attributes[i].name;
    hv_free(ctx, image->attributes[i].string);
    image->attributes[i] = value;
    return HETINV_SUCCESS;
  }
  value.name = hv_strdup(ctx, name);
  if (value.name != NULL && image->attribute_count == image->attribute_capacity) {
    int32_t capacity = image->attribute_capacity > 0 ? 2 * image->attribute_capacity : 8;
    hv_image_attribute_t *grown = hv_calloc(ctx, (size_t)capacity, sizeof *grown);
    if (grown == NULL) {
      hv_free(ctx, value.name);
      value.name = NULL;
    } else {
      if (image->attribute_count > 0) {
        memcpy(grown, image->attributes, (size_t)image->attribute_count * sizeof *grown);
      }
      hv_free(ctx, image->attributes);
      image->attributes = grown;
      image->attribute_capacity = capacity;
    }
  }
  if (value.name == NULL) {
    hv_free(ctx, value.string);
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate attribute \"%s\"", name);
  }
  image->attributes[image->attribute_count++] = value;
  return HETINV_SUCCESS;
}

/* Common checks of the three setters. */
static hetinv_result_t check_attribute_name(const hetinv_image_t *image, const char *name) {
  if (image == NULL) return HV_FAIL(NULL, HETINV_ERROR_NULL_ARGUMENT, "'image' is NULL");
  if (name == NULL) return HV_FAIL(image->ctx, HETINV_ERROR_NULL_ARGUMENT, "'name' is NULL");
  if (!hv_image_name_is_valid(name)) return fail_name(image->ctx, "attribute name", name);
  if (hv_image_attribute_is_reserved(name)) {
    return HV_FAIL(image->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "attribute name \"%s\" is reserved (OpenEXR or libhetinv writes it itself)",
                   name);
  }
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_image_set_attribute_string(hetinv_image_t *image,
                                                             const char *name, const char *value) {
  HV_API_ENTER();
  hetinv_result_t r = check_attribute_name(image, name);
  if (r != HETINV_SUCCESS) return r;
  HV_CHECK_NULL(image->ctx, value);
  size_t n = strlen(value);
  if (n > HV_IMAGE_STRING_MAX) {
    return HV_FAIL(image->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the value of attribute \"%s\" is %zu bytes long; at most %d are allowed", name,
                   n, HV_IMAGE_STRING_MAX);
  }
  return hv_image_store_attribute(image, name, HETINV_ATTRIBUTE_STRING, value, 0.0, 0);
}

HETINV_API hetinv_result_t hetinv_image_set_attribute_double(hetinv_image_t *image,
                                                             const char *name, double value) {
  HV_API_ENTER();
  hetinv_result_t r = check_attribute_name(image, name);
  if (r != HETINV_SUCCESS) return r;
  if (!isfinite(value)) {
    return HV_FAIL(image->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the value of attribute \"%s\" is %g; it must be finite", name, value);
  }
  return hv_image_store_attribute(image, name, HETINV_ATTRIBUTE_DOUBLE, NULL, value, 0);
}

HETINV_API hetinv_result_t hetinv_image_set_attribute_int(hetinv_image_t *image, const char *name,
                                                          int32_t value) {
  HV_API_ENTER();
  hetinv_result_t r = check_attribute_name(image, name);
  if (r != HETINV_SUCCESS) return r;
  return hv_image_store_attribute(image, name, HETINV_ATTRIBUTE_INT, NULL, 0.0, value);
}

HETINV_API int32_t hetinv_image_attribute_count(const hetinv_image_t *image) {
  HV_API_ENTER();
  return image != NULL ? image->attribute_count : 0;
}

HETINV_API hetinv_result_t hetinv_image_attribute_at(const hetinv_image_t *image, int32_t index,
                                                     const char **name,
                                                     hetinv_attribute_type_t *type) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, image);
  if (index < 0 || index >= image->attribute_count) {
    return HV_FAIL(image->ctx, HETINV_ERROR_OUT_OF_RANGE,
                   "index is %d; the image has %d attributes", (int)index,
                   (int)image->attribute_count);
  }
  if (name != NULL) *name = image->attributes[index].name;
  if (type != NULL) *type = image->attributes[index].type;
  return HETINV_SUCCESS;
}

static const char *type_name(hetinv_attribute_type_t type) {
  switch (type) {
    case HETINV_ATTRIBUTE_STRING: return "a string";
    case HETINV_ATTRIBUTE_DOUBLE: return "a double";
    default: return "an int";
  }
}

/* The attribute called @p name if it has type @p type, else a failure. */
static hetinv_result_t lookup(const hetinv_image_t *image, const char *name,
                              const void *value, hetinv_attribute_type_t type,
                              const hv_image_attribute_t **found) {
  if (image == NULL) return HV_FAIL(NULL, HETINV_ERROR_NULL_ARGUMENT, "'image' is NULL");
  if (name == NULL) return HV_FAIL(image->ctx, HETINV_ERROR_NULL_ARGUMENT, "'name' is NULL");
  if (value == NULL) {
    return HV_FAIL(image->ctx, HETINV_ERROR_NULL_ARGUMENT, "'value' is NULL");
  }
  int32_t i = find_attribute(image, name);
  if (i < 0) {
    return HV_FAIL(image->ctx, HETINV_ERROR_OUT_OF_RANGE, "no attribute is called \"%s\"", name);
  }
  if (image->attributes[i].type != type) {
    return HV_FAIL(image->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "attribute \"%s\" is %s, not %s", name, type_name(image->attributes[i].type),
                   type_name(type));
  }
  *found = &image->attributes[i];
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_image_get_attribute_string(const hetinv_image_t *image,
                                                             const char *name, const char **value) {
  HV_API_ENTER();
  const hv_image_attribute_t *a = NULL;
  hetinv_result_t r = lookup(image, name, value, HETINV_ATTRIBUTE_STRING, &a);
  if (r == HETINV_SUCCESS) *value = a->string;
  return r;
}

HETINV_API hetinv_result_t hetinv_image_get_attribute_double(const hetinv_image_t *image,
                                                             const char *name, double *value) {
  HV_API_ENTER();
  const hv_image_attribute_t *a = NULL;
  hetinv_result_t r = lookup(image, name, value, HETINV_ATTRIBUTE_DOUBLE, &a);
  if (r == HETINV_SUCCESS) *value = a->real;
  return r;
}

HETINV_API hetinv_result_t hetinv_image_get_attribute_int(const hetinv_image_t *image,
                                                          const char *name, int32_t *value) {
  HV_API_ENTER();
  const hv_image_attribute_t *a = NULL;
  hetinv_result_t r = lookup(image, name, value, HETINV_ATTRIBUTE_INT, &a);
  if (r == HETINV_SUCCESS) *value = a->integer;
  return r;
}
