#include "exr_support.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static hetinv_context_t *context;
static char dir[256];
static char path[512];
static const char *const made[] = {"in.exr", "out.exr"};

static void cleanup(void) {
  for (size_t i = 0; i < sizeof made / sizeof made[0]; ++i) unlink(fx_path(made[i]));
  rmdir(dir);
  hetinv_context_destroy(&context);
}

hetinv_context_t *fx_context(void) {
  if (context != NULL) return context;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 1;
  CHECK(hetinv_context_create(&init, &context) == HETINV_SUCCESS);
  /* TMPDIR, else memory (the writer fsyncs every file), else /tmp */
  const char *tmp = getenv("TMPDIR");
  if (tmp == NULL || *tmp == '\0') tmp = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
  snprintf(dir, sizeof dir, "%s/hetinv-fuzz-exr-XXXXXX", tmp);
  CHECK(mkdtemp(dir) != NULL);
  atexit(cleanup);
  return context;
}

const char *fx_path(const char *name) {
  snprintf(path, sizeof path, "%s/%s", dir, name);
  return path;
}

void fx_write_file(const char *file, const uint8_t *data, size_t size) {
  FILE *f = fopen(file, "wb");
  CHECK(f != NULL);
  CHECK(size == 0 || fwrite(data, 1, size, f) == size);
  CHECK(fclose(f) == 0);
}

void fx_check_same(const hetinv_image_t *a, const hetinv_image_t *b) {
  int32_t wa, ha, ca, wb, hb, cb;
  CHECK(hetinv_image_get_size(a, &wa, &ha, &ca) == HETINV_SUCCESS);
  CHECK(hetinv_image_get_size(b, &wb, &hb, &cb) == HETINV_SUCCESS);
  CHECK(wa == wb && ha == hb && ca == cb);
  for (int32_t k = 0; k < ca; ++k) {
    CHECK(strcmp(hetinv_image_channel_name(a, k), hetinv_image_channel_name(b, k)) == 0);
    const float *pa = hetinv_image_channel_data((hetinv_image_t *)(uintptr_t)a, k);
    const float *pb = hetinv_image_channel_data((hetinv_image_t *)(uintptr_t)b, k);
    CHECK(memcmp(pa, pb, (size_t)wa * (size_t)ha * sizeof(float)) == 0);
  }
  int32_t n = hetinv_image_attribute_count(a);
  CHECK(hetinv_image_attribute_count(b) == n);
  for (int32_t i = 0; i < n; ++i) {
    const char *name_a, *name_b;
    hetinv_attribute_type_t ta, tb;
    CHECK(hetinv_image_attribute_at(a, i, &name_a, &ta) == HETINV_SUCCESS);
    CHECK(hetinv_image_attribute_at(b, i, &name_b, &tb) == HETINV_SUCCESS);
    CHECK(strcmp(name_a, name_b) == 0 && ta == tb);
    if (ta == HETINV_ATTRIBUTE_STRING) {
      const char *sa, *sb;
      CHECK(hetinv_image_get_attribute_string(a, name_a, &sa) == HETINV_SUCCESS);
      CHECK(hetinv_image_get_attribute_string(b, name_b, &sb) == HETINV_SUCCESS);
      CHECK(strcmp(sa, sb) == 0);
    } else if (ta == HETINV_ATTRIBUTE_DOUBLE) {
      double da, db;
      CHECK(hetinv_image_get_attribute_double(a, name_a, &da) == HETINV_SUCCESS);
      CHECK(hetinv_image_get_attribute_double(b, name_b, &db) == HETINV_SUCCESS);
      CHECK(memcmp(&da, &db, sizeof da) == 0);
    } else {
      int32_t ia, ib;
      CHECK(hetinv_image_get_attribute_int(a, name_a, &ia) == HETINV_SUCCESS);
      CHECK(hetinv_image_get_attribute_int(b, name_b, &ib) == HETINV_SUCCESS);
      CHECK(ia == ib);
    }
  }
}
