/* The context's fields, shared by the library's subsystems (never installed). */
#ifndef HV_CONTEXT_INTERNAL_H
#define HV_CONTEXT_INTERNAL_H

#include "hetinv/context.h"

struct hetinv_context {
  hetinv_alloc_fn alloc_fn;
  hetinv_free_fn free_fn;
  void *alloc_user_data;
  hetinv_error_fn error_fn;
  void *error_user_data;
  int32_t thread_count; /* resolved: always >= 1 */
  uint64_t seed;
};

#endif
