/**
 * @file export.h
 * @brief Symbol visibility for the public API.
 *
 * The library is built with hidden visibility; only declarations marked
 * HETINV_API are exported from the shared object. Consumers never need to
 * define anything: HETINV_BUILDING is set by the library's own build only.
 */
#ifndef HETINV_EXPORT_H
#define HETINV_EXPORT_H

#if defined(_WIN32)
#  if defined(HETINV_BUILDING)
#    define HETINV_API __declspec(dllexport)
#  else
#    define HETINV_API __declspec(dllimport)
#  endif
#elif defined(__GNUC__) || defined(__clang__)
#  define HETINV_API __attribute__((visibility("default")))
#else
#  define HETINV_API
#endif

#endif /* HETINV_EXPORT_H */
