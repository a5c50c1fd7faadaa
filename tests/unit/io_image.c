/* The image handle: size, planar channels, names, attributes, validation. */
#include <math.h>
#include <stdlib.h>

#include "test_support.h"

static hetinv_image_t *make(hetinv_context_t *ctx, int32_t w, int32_t h, int32_t c) {
  hetinv_image_t *img = NULL;
  assert_ok(hetinv_image_create(ctx, w, h, c, &img));
  assert_non_null(img);
  return img;
}

/* A string of @p n copies of @p ch (caller frees). */
static char *repeat(char ch, size_t n) {
  char *s = malloc(n + 1);
  assert_non_null(s);
  memset(s, ch, n);
  s[n] = '\0';
  return s;
}

static void new_image_is_zeroed_with_default_names(void **state) {
  hetinv_image_t *img = make(*state, 5, 3, 4);
  int32_t w = 0, h = 0, c = 0;
  assert_ok(hetinv_image_get_size(img, &w, &h, &c));
  assert_int_equal(w, 5);
  assert_int_equal(h, 3);
  assert_int_equal(c, 4);
  assert_ok(hetinv_image_get_size(img, NULL, NULL, NULL)); /* outputs are optional */
  static const char *const names[] = {"c0", "c1", "c2", "c3"};
  for (int32_t k = 0; k < 4; ++k) {
    assert_string_equal(hetinv_image_channel_name(img, k), names[k]);
    const float *p = hetinv_image_channel_data(img, k);
    assert_non_null(p);
    for (int i = 0; i < 15; ++i) assert_true(p[i] == 0.0f);
  }
  assert_int_equal(hetinv_image_attribute_count(img), 0);
  hetinv_image_destroy(&img);
  assert_null(img);
}

static void channels_are_planar_row_major(void **state) {
  hetinv_image_t *img = make(*state, 4, 3, 2);
  float *a = hetinv_image_channel_data(img, 0), *b = hetinv_image_channel_data(img, 1);
  assert_ptr_equal(b, a + 12); /* one plane after the other */
  a[2 * 4 + 3] = 7.0f;          /* pixel (3, 2) */
  assert_true(hetinv_image_channel_data(img, 0)[11] == 7.0f);
  assert_true(b[11] == 0.0f);
  assert_null(hetinv_image_channel_data(img, 2));
  assert_null(hetinv_image_channel_data(img, -1));
  assert_null(hetinv_image_channel_data(NULL, 0));
  assert_null(hetinv_image_channel_name(img, 2));
  assert_null(hetinv_image_channel_name(NULL, 0));
  hetinv_image_destroy(&img);
}

static void create_rejects_bad_arguments(void **state) {
  hetinv_context_t *ctx = *state;
  hetinv_image_t *img = (hetinv_image_t *)&img; /* must be reset to NULL */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_image_create(ctx, 0, 3, 1, &img));
  assert_null(img);
  assert_message_contains("hetinv_image_create: width is 0; it must be > 0");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_image_create(ctx, 3, -2, 1, &img));
  assert_message_contains("height is -2");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_image_create(ctx, 3, 2, 0, &img));
  assert_message_contains("channel_count is 0");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_create(ctx, 3, 2, 1, NULL));
  assert_message_contains("'out' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_create(NULL, 3, 2, 1, &img));
  assert_message_contains("'ctx' is NULL");
  assert_null(img);
}

static void create_detects_size_overflow(void **state) {
  hetinv_image_t *img = NULL;
  assert_result(HETINV_ERROR_SIZE_OVERFLOW,
                hetinv_image_create(*state, INT32_MAX, INT32_MAX, INT32_MAX, &img));
  assert_message_contains("overflow size_t");
  assert_null(img);
}

static void *small_alloc(void *user, size_t size) {
  (void)user;
  return size > (1u << 20) ? NULL : malloc(size);
}
static void plain_free(void *user, void *ptr) {
  (void)user;
  free(ptr);
}

static void create_reports_allocation_failure(void **state) {
  (void)state;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.alloc_fn = small_alloc;
  init.free_fn = plain_free;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&init, &ctx));
  hetinv_image_t *img = NULL;
  assert_result(HETINV_ERROR_OUT_OF_MEMORY, hetinv_image_create(ctx, 1024, 1024, 8, &img));
  assert_message_contains("1024 x 1024 image of 8 channels");
  assert_null(img);
  hetinv_context_destroy(&ctx);
}

static void destroy_and_accessors_accept_null(void **state) {
  (void)state;
  hetinv_image_destroy(NULL);
  hetinv_image_t *img = NULL;
  hetinv_image_destroy(&img);
  assert_int_equal(hetinv_image_attribute_count(NULL), 0);
  int32_t w;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_get_size(NULL, &w, NULL, NULL));
  assert_message_contains("'image' is NULL");
}

static void channels_can_be_renamed_and_found(void **state) {
  hetinv_image_t *img = make(*state, 2, 2, 3);
  assert_ok(hetinv_image_set_channel_name(img, 1, "tau001"));
  assert_ok(hetinv_image_set_channel_name(img, 1, "tau001")); /* its own name again */
  assert_string_equal(hetinv_image_channel_name(img, 1), "tau001");
  int32_t c = -7;
  assert_ok(hetinv_image_find_channel(img, "tau001", &c));
  assert_int_equal(c, 1);
  assert_ok(hetinv_image_find_channel(img, "c2", &c));
  assert_int_equal(c, 2);
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_image_find_channel(img, "c1", &c));
  assert_int_equal(c, -1);
  assert_message_contains("no channel is called \"c1\"");
  char *longest = repeat('x', 255);
  assert_ok(hetinv_image_set_channel_name(img, 0, longest));
  assert_string_equal(hetinv_image_channel_name(img, 0), longest);
  free(longest);
  hetinv_image_destroy(&img);
}

static void bad_channel_names_are_rejected(void **state) {
  hetinv_image_t *img = make(*state, 2, 2, 3);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_image_set_channel_name(img, 0, "c2"));
  assert_message_contains("channel name \"c2\" is already used by channel 2");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_image_set_channel_name(img, 0, ""));
  assert_message_contains("the channel name is empty");
  char *too_long = repeat('y', 256);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_image_set_channel_name(img, 0, too_long));
  assert_message_contains("the channel name is 256 bytes long; at most 255 are allowed");
  free(too_long);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_image_set_channel_name(img, 0, "a\tb"));
  assert_message_contains("byte 0x09 at offset 1");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_image_set_channel_name(img, 0, "caf\xc3\xa9"));
  assert_message_contains("byte 0xC3 at offset 3");
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_image_set_channel_name(img, 3, "x"));
  assert_message_contains("channel is 3; the image has 3 channels (0 to 2)");
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_image_set_channel_name(img, -1, "x"));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_set_channel_name(img, 0, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_set_channel_name(NULL, 0, "x"));
  int32_t c;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_find_channel(img, NULL, &c));
  assert_int_equal(c, -1);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_find_channel(img, "c0", NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_find_channel(NULL, "c0", &c));
  assert_string_equal(hetinv_image_channel_name(img, 0), "c0"); /* unchanged */
  hetinv_image_destroy(&img);
}

static void attributes_of_each_type_are_kept_in_order(void **state) {
  hetinv_image_t *img = make(*state, 1, 1, 1);
  assert_ok(hetinv_image_set_attribute_string(img, "hetinv:units", "1/mm"));
  assert_ok(hetinv_image_set_attribute_double(img, "bin_width", 0.025));
  assert_ok(hetinv_image_set_attribute_int(img, "photons", -12));
  assert_int_equal(hetinv_image_attribute_count(img), 3);
  static const char *const names[] = {"hetinv:units", "bin_width", "photons"};
  static const hetinv_attribute_type_t types[] = {HETINV_ATTRIBUTE_STRING,
                                                  HETINV_ATTRIBUTE_DOUBLE, HETINV_ATTRIBUTE_INT};
  for (int32_t i = 0; i < 3; ++i) {
    const char *name = NULL;
    hetinv_attribute_type_t type = -1;
    assert_ok(hetinv_image_attribute_at(img, i, &name, &type));
    assert_string_equal(name, names[i]);
    assert_int_equal(type, types[i]);
  }
  assert_ok(hetinv_image_attribute_at(img, 0, NULL, NULL));
  const char *s = NULL;
  double d = 0;
  int32_t n = 0;
  assert_ok(hetinv_image_get_attribute_string(img, "hetinv:units", &s));
  assert_string_equal(s, "1/mm");
  assert_ok(hetinv_image_get_attribute_double(img, "bin_width", &d));
  assert_true(d == 0.025);
  assert_ok(hetinv_image_get_attribute_int(img, "photons", &n));
  assert_int_equal(n, -12);
  hetinv_image_destroy(&img);
}

static void setting_again_replaces_in_place(void **state) {
  hetinv_image_t *img = make(*state, 1, 1, 1);
  assert_ok(hetinv_image_set_attribute_string(img, "a", "first"));
  assert_ok(hetinv_image_set_attribute_int(img, "b", 1));
  assert_ok(hetinv_image_set_attribute_string(img, "a", "second"));
  assert_ok(hetinv_image_set_attribute_double(img, "b", 2.5)); /* the type may change */
  assert_int_equal(hetinv_image_attribute_count(img), 2);
  const char *name = NULL, *s = NULL;
  hetinv_attribute_type_t type;
  assert_ok(hetinv_image_attribute_at(img, 1, &name, &type));
  assert_string_equal(name, "b");
  assert_int_equal(type, HETINV_ATTRIBUTE_DOUBLE);
  assert_ok(hetinv_image_get_attribute_string(img, "a", &s));
  assert_string_equal(s, "second");
  for (int i = 0; i < 100; ++i) { /* growth keeps earlier entries */
    char key[16];
    snprintf(key, sizeof key, "k%d", i);
    assert_ok(hetinv_image_set_attribute_int(img, key, i));
  }
  int32_t v = 0;
  assert_ok(hetinv_image_get_attribute_int(img, "k57", &v));
  assert_int_equal(v, 57);
  assert_ok(hetinv_image_get_attribute_string(img, "a", &s));
  assert_string_equal(s, "second");
  assert_int_equal(hetinv_image_attribute_count(img), 102);
  hetinv_image_destroy(&img);
}

static void attribute_lookups_fail_precisely(void **state) {
  hetinv_image_t *img = make(*state, 1, 1, 1);
  assert_ok(hetinv_image_set_attribute_double(img, "scale", 2.0));
  const char *s;
  double d;
  int32_t n;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_image_get_attribute_string(img, "scale", &s));
  assert_message_contains("attribute \"scale\" is a double, not a string");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_image_get_attribute_int(img, "scale", &n));
  assert_message_contains("is a double, not an int");
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_image_get_attribute_double(img, "scal", &d));
  assert_message_contains("no attribute is called \"scal\"");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_get_attribute_double(img, "scale", NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_get_attribute_double(img, NULL, &d));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_get_attribute_double(NULL, "scale", &d));
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_image_attribute_at(img, 1, NULL, NULL));
  assert_message_contains("index is 1; the image has 1 attributes");
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_image_attribute_at(img, -1, NULL, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_attribute_at(NULL, 0, NULL, NULL));
  hetinv_image_destroy(&img);
}

static void bad_attributes_are_rejected(void **state) {
  hetinv_image_t *img = make(*state, 1, 1, 1);
  static const char *const reserved[] = {"channels", "compression", "dataWindow",
                                         "displayWindow", "lineOrder", "tiles", "type", "name",
                                         "chunkCount", "hetinv:channelOrder"};
  for (size_t i = 0; i < sizeof reserved / sizeof reserved[0]; ++i) {
    assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                  hetinv_image_set_attribute_int(img, reserved[i], 1));
    assert_message_contains("is reserved");
  }
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_image_set_attribute_int(img, "", 1));
  assert_message_contains("hetinv_image_set_attribute_int: the attribute name is empty");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_image_set_attribute_string(img, "new\nline", "x"));
  assert_message_contains("byte 0x0A at offset 3");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_image_set_attribute_double(img, "x", (double)NAN));
  assert_message_contains("the value of attribute \"x\" is nan; it must be finite");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_image_set_attribute_double(img, "x", -HUGE_VAL));
  char *big = repeat('s', 65536);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_image_set_attribute_string(img, "x", big));
  assert_message_contains("is 65536 bytes long; at most 65535 are allowed");
  big[65535] = '\0';
  assert_ok(hetinv_image_set_attribute_string(img, "x", big));
  free(big);
  assert_ok(hetinv_image_set_attribute_string(img, "empty", ""));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_set_attribute_string(img, "x", NULL));
  assert_message_contains("'value' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_set_attribute_int(img, NULL, 1));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_set_attribute_int(NULL, "x", 1));
  assert_int_equal(hetinv_image_attribute_count(img), 2); /* only the valid ones */
  hetinv_image_destroy(&img);
}

static void *counting_alloc(void *user, size_t size) {
  ++((int *)user)[0];
  return malloc(size);
}
static void counting_free(void *user, void *ptr) {
  ++((int *)user)[1];
  free(ptr);
}

static void allocations_are_balanced(void **state) {
  (void)state;
  int counts[2] = {0, 0};
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.alloc_fn = counting_alloc;
  init.free_fn = counting_free;
  init.alloc_user_data = counts;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&init, &ctx));
  hetinv_image_t *img = make(ctx, 3, 3, 5);
  assert_ok(hetinv_image_set_channel_name(img, 4, "last"));
  assert_ok(hetinv_image_set_attribute_string(img, "s", "v"));
  assert_ok(hetinv_image_set_attribute_string(img, "s", "w"));
  assert_ok(hetinv_image_set_attribute_double(img, "s", 1.0));
  hetinv_image_destroy(&img);
  hetinv_context_destroy(&ctx);
  assert_true(counts[0] > 5);
  assert_int_equal(counts[0], counts[1]);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(new_image_is_zeroed_with_default_names),
      cmocka_unit_test(channels_are_planar_row_major),
      cmocka_unit_test(create_rejects_bad_arguments),
      cmocka_unit_test(create_detects_size_overflow),
      cmocka_unit_test(create_reports_allocation_failure),
      cmocka_unit_test(destroy_and_accessors_accept_null),
      cmocka_unit_test(channels_can_be_renamed_and_found),
      cmocka_unit_test(bad_channel_names_are_rejected),
      cmocka_unit_test(attributes_of_each_type_are_kept_in_order),
      cmocka_unit_test(setting_again_replaces_in_place),
      cmocka_unit_test(attribute_lookups_fail_precisely),
      cmocka_unit_test(bad_attributes_are_rejected),
      cmocka_unit_test(allocations_are_balanced),
  };
  return cmocka_run_group_tests(tests, ht_context_setup, ht_context_teardown);
}
