// A C++ program built against the installed library only: the C headers must
// compile as C++ (extern "C", no C-only constructs in their macros) and link.
#include <hetinv/hetinv.h>

#include <cstdint>
#include <cstdio>

int main() {
  if (hetinv_version_number() != HETINV_VERSION_NUMBER) {
    std::fprintf(stderr, "header %s, library %s\n", HETINV_VERSION_STRING, hetinv_version_string());
    return 1;
  }
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 1;
  hetinv_context_t *ctx = nullptr;
  hetinv_medium_t *m = nullptr;
  hetinv_param_map_t *map = nullptr;
  const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
  const std::int32_t dims[3] = {4, 4, 4};
  hetinv_stage_t stage = {};
  stage.size = HETINV_STAGE_SIZE_V2;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS ||
      hetinv_medium_create(ctx, lo, hi, dims, &m) != HETINV_SUCCESS ||
      hetinv_medium_fill(m, 1.0, 10.0, 0.5) != HETINV_SUCCESS || hetinv_medium_commit(m) != HETINV_SUCCESS ||
      hetinv_param_map_create_identity(m, HETINV_FREE_ALL, &map) != HETINV_SUCCESS) {
    std::fprintf(stderr, "failed: %s\n", hetinv_context_last_error_message(nullptr));
    return 1;
  }
  std::printf("C++ consumer ok: libhetinv %s, %zu voxels, %zu entries, stage size %zu\n", hetinv_version_string(),
              hetinv_medium_voxel_count(m), hetinv_param_map_size(map), stage.size);
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return 0;
}
