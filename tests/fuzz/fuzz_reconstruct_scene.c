/* libFuzzer harness of hetinv-reconstruct's scene reader (examples/
 * reconstruct/scene.c and the size checks of imaging.c): every input is
 * read over the built-in scene and checked (recon_scene_parse), and for an
 * accepted scene the sizes it implies must be within the library's bounds,
 * as recon_scene_check() promises. Nothing is built or rendered. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "recon.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define CHECK(cond) \
  do { \
    if (!(cond)) __builtin_trap(); \
  } while (0)

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  char *text = malloc(size + 1);
  if (text == NULL) return 0;
  memcpy(text, data, size);
  text[size] = '\0';
  recon_scene_t sc;
  recon_scene_default(&sc);
  char msg[4096];
  if (recon_scene_parse("fuzz.json", text, &sc, msg, sizeof msg) == 0) {
    recon_imaging_size_t n;
    recon_imaging_size(&sc, &n);
    CHECK(n.emitters <= RECON_MAX_EMITTERS);
    CHECK(n.rows <= HETINV_MAX_MEASUREMENT_ROWS);
    CHECK(n.values <= (double)HETINV_MAX_MEASUREMENT_VALUES);
    CHECK(sc.iterations >= 1 && sc.iterations <= INT32_MAX);
    CHECK(sc.coarse_fraction > 0.0 && ceil(sc.coarse_fraction * (double)sc.iterations) <= INT32_MAX);
    CHECK(sc.config == RECON_STEADY || recon_bin_count(&sc) <= HETINV_MAX_PATHLENGTH_BINS);
    CHECK(sc.threads >= 0 && sc.threads <= HETINV_MAX_THREADS);
    CHECK(sc.level_count >= 1 && sc.level_count + sc.layerwise_layers <= HETINV_MAX_STAGES);
  } else {
    CHECK(msg[0] != '\0'); /* every failure says why */
  }
  free(text);
  return 0;
}
