/**
 * @file result.h
 * @brief Result codes returned by every fallible libhetinv call.
 *
 * A call returns HETINV_SUCCESS (0) or one of the codes below. The codes are
 * pinned: a value never changes meaning and new codes are only appended.
 * The result type is a plain int32_t, kept apart from the enum, so that the
 * enum can grow without changing the ABI.
 *
 * A failing call also records a detailed message (which value, where) for the
 * calling thread; read it with hetinv_context_last_error_message() and, if a
 * context has an error callback, the callback receives it too.
 */
#ifndef HETINV_RESULT_H
#define HETINV_RESULT_H

#include <stdint.h>

#include "hetinv/export.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Return type of every fallible call: one of enum hetinv_result_code. */
typedef int32_t hetinv_result_t;

/** Pinned result codes. Never renumbered; new codes are appended. */
enum hetinv_result_code {
  HETINV_SUCCESS = 0,                /**< the call did what it says */
  HETINV_ERROR_NULL_ARGUMENT = 1,    /**< a required pointer argument was NULL */
  HETINV_ERROR_INVALID_ARGUMENT = 2, /**< a value is not allowed (NaN, negative σ, |g| >= 1, ...) */
  HETINV_ERROR_OUT_OF_RANGE = 3,     /**< an index or name does not exist (voxel, channel, attribute) */
  HETINV_ERROR_OUT_OF_MEMORY = 4,    /**< the allocator returned NULL */
  HETINV_ERROR_INVALID_STATE = 5,    /**< the object is not in a state that allows the call (e.g. modifying a committed medium) */
  HETINV_ERROR_IO = 6,               /**< the operating system refused a file operation */
  HETINV_ERROR_CORRUPT_FILE = 7,     /**< a file is malformed: wrong magic, truncated, NaN payload, inconsistent header */
  HETINV_ERROR_UNSUPPORTED = 8,      /**< well-formed input using a feature this version does not implement */
  HETINV_ERROR_SIZE_OVERFLOW = 9,    /**< dimensions whose product does not fit in memory sizes */
  HETINV_ERROR_INTERNAL = 10,        /**< a bug in libhetinv or a dependency; please report it */
  HETINV_RESULT_CODE_COUNT_ = 11     /**< not a code: one past the last code of this version */
};

/**
 * @brief Static, human-readable name of a result code, e.g.
 *        "HETINV_ERROR_INVALID_ARGUMENT".
 * @param code any integer.
 * @return a static string, never NULL; "HETINV_UNKNOWN_RESULT" for a value
 *         that is not a code of this version. Thread-safe.
 */
HETINV_API const char *hetinv_result_name(hetinv_result_t code);

#ifdef __cplusplus
}
#endif

#endif /* HETINV_RESULT_H */
