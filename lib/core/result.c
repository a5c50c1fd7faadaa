#include "hetinv/result.h"
#include "core/error.h"

HETINV_API const char *hetinv_result_name(hetinv_result_t code) {
  HV_API_ENTER();
  /* Indexed by the pinned codes of result.h. */
  static const char *const names[HETINV_RESULT_CODE_COUNT_] = {
      "HETINV_SUCCESS",
      "HETINV_ERROR_NULL_ARGUMENT",
      "HETINV_ERROR_INVALID_ARGUMENT",
      "HETINV_ERROR_OUT_OF_RANGE",
      "HETINV_ERROR_OUT_OF_MEMORY",
      "HETINV_ERROR_INVALID_STATE",
      "HETINV_ERROR_IO",
      "HETINV_ERROR_CORRUPT_FILE",
      "HETINV_ERROR_UNSUPPORTED",
      "HETINV_ERROR_SIZE_OVERFLOW",
      "HETINV_ERROR_INTERNAL",
  };
  if (code < 0 || code >= HETINV_RESULT_CODE_COUNT_) return "HETINV_UNKNOWN_RESULT";
  return names[code];
}
