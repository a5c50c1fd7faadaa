#include "hetinv/version.h"

HETINV_API unsigned hetinv_version_number(void) { return HETINV_VERSION_NUMBER; }

HETINV_API const char *hetinv_version_string(void) { return HETINV_VERSION_STRING; }
