/* A program built against the installed library only. */
#include <hetinv/hetinv.h>
#include <stdio.h>

int main(void) {
  if (hetinv_version_number() != HETINV_VERSION_NUMBER) {
    fprintf(stderr, "header %s, library %s\n", HETINV_VERSION_STRING, hetinv_version_string());
    return 1;
  }
  hetinv_context_t *ctx = NULL;
  hetinv_medium_t *m = NULL;
  const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
  const int32_t dims[3] = {4, 4, 4};
  if (hetinv_context_create(NULL, &ctx) != HETINV_SUCCESS ||
      hetinv_medium_create(ctx, lo, hi, dims, &m) != HETINV_SUCCESS ||
      hetinv_medium_fill(m, 1.0, 10.0, 0.5) != HETINV_SUCCESS ||
      hetinv_medium_commit(m) != HETINV_SUCCESS) {
    fprintf(stderr, "failed: %s\n", hetinv_context_last_error_message(NULL));
    return 1;
  }
  printf("consumer ok: libhetinv %s, %zu voxels\n", hetinv_version_string(),
         hetinv_medium_voxel_count(m));
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return 0;
}
