/* libFuzzer harness of hetinv-render's scene reader (examples/render/
 * scene*.c): every input is parsed as a scene file, and a scene that
 * parses is built into library objects (medium, emitters, sensors,
 * pathlengths, measurement set) and configures an estimator. Nothing is
 * rendered. The reader must never crash, and must check every count and
 * size before it allocates: the library's allocations go through a hook
 * that refuses anything over MAX_ALLOC (the library then fails cleanly),
 * and libFuzzer's -malloc_limit_mb catches the examples' own. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Largest single library allocation granted: a 2^24-voxel medium's 400 MB
 * would be legitimate, but is not what the fuzzer is here to exercise. */
enum { MAX_ALLOC = 64 << 20 };

static void *capped_alloc(void *user, size_t n) {
  (void)user;
  return n > MAX_ALLOC ? NULL : malloc(n);
}

static void capped_free(void *user, void *p) {
  (void)user;
  free(p);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static int stdin_closed;
  if (!stdin_closed) { /* a "vol" path of /dev/stdin must not wait for input */
    FILE *f = freopen("/dev/null", "r", stdin);
    (void)f;
    stdin_closed = 1;
  }
  char *text = malloc(size + 1);
  if (text == NULL) return 0;
  memcpy(text, data, size);
  text[size] = '\0';
  /* A folder that does not exist: relative .vol paths of the input find nothing. */
  static const char path[] = "/nonexistent-hetinv-fuzz/scene.json";
  jr_t jr = {0};
  scene_t sc;
  if (scene_load_text(&sc, path, text, &jr) == 0) {
    hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
    init.alloc_fn = capped_alloc;
    init.free_fn = capped_free;
    init.thread_count = 1;
    init.seed = sc.seed;
    hetinv_context_t *ctx = NULL;
    hetinv_estimator_t *est = NULL;
    if (hetinv_context_create(&init, &ctx) == HETINV_SUCCESS &&
        scene_build(&sc, ctx, &jr) == 0 && hetinv_estimator_create(ctx, &est) == HETINV_SUCCESS) {
      (void)scene_configure_estimator(&sc, est, "photons", &jr);
    }
    hetinv_estimator_destroy(&est);
    scene_destroy(&sc);
    hetinv_context_destroy(&ctx);
  } else {
    scene_destroy(&sc);
  }
  return 0;
}
