#include "hetinv/version.h"
#include "core/error.h"

HETINV_API unsigned hetinv_version_number(void) {
  HV_API_ENTER();
  return HETINV_VERSION_NUMBER;
}

HETINV_API const char *hetinv_version_string(void) {
  HV_API_ENTER();
  return HETINV_VERSION_STRING;
}
