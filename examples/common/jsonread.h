/* Reading a JSON scene with messages that name the offending field.
 *
 * Every reader takes the path of the object it reads from ("emitters[2]")
 * and a key; on failure it records "<file>: <path>.<key>: <what is wrong>"
 * in the jr_t and returns -1. A missing optional field leaves the output
 * untouched (so callers preset defaults) and returns 0; a present field
 * returns 1.
 */
#ifndef HETINV_EXAMPLES_JSONREAD_H
#define HETINV_EXAMPLES_JSONREAD_H

#include <stddef.h>
#include <stdint.h>

#include <cjson/cJSON.h>

/** Longest field path kept ("emitters[2].sources[10].direction"). */
#define JR_PATH_MAX 256

typedef struct jr {
  const char *file;    /* scene file name, first part of every message */
  char message[4096];  /* the last failure */
} jr_t;

enum { JR_OPTIONAL = 0, JR_REQUIRED = 1 };

#if defined(__GNUC__) || defined(__clang__)
#define JR_PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define JR_PRINTF(f, a)
#endif

/* Records "<file>: <path>: <message>" (path may be "") and returns -1. */
int jr_fail(jr_t *jr, const char *path, const char *fmt, ...) JR_PRINTF(3, 4);

/* out = "parent.key" ("key" when parent is empty); out = "parent[index]". */
void jr_key(char out[JR_PATH_MAX], const char *parent, const char *key);
void jr_index(char out[JR_PATH_MAX], const char *parent, int index);

/* "a string", "an array of 2 elements", ...: what a value is, for messages. */
const char *jr_describe(const cJSON *item, char *buf, size_t size);

/* The member called key (case-sensitive), or NULL. */
const cJSON *jr_get(const cJSON *object, const char *key);

/* item must be an object whose keys are all in the NULL-terminated list
 * allowed, each once. */
int jr_check_object(jr_t *jr, const cJSON *item, const char *path, const char *const *allowed);

/* Reads the file at path and parses it; on failure records "cannot open",
 * "file:line:col: JSON syntax error near ..." etc. The caller frees *text
 * (free) and *root (cJSON_Delete), also after a failure. */
int jr_load(jr_t *jr, const char *path, char **text, cJSON **root);

/* Parses text (NUL-terminated, read from jr->file) like jr_load; the
 * caller frees *root (cJSON_Delete), also after a failure. */
int jr_parse(jr_t *jr, const char *text, cJSON **root);

/* A finite number. */
int jr_number(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
              double *out);
/* A finite number > 0. */
int jr_positive(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
                double *out);
/* The largest integer a JSON number is read as exactly: cJSON keeps numbers
 * as doubles, so 2^53 + 1 would arrive as 2^53. */
#define JR_INTEGER_MAX 9007199254740991LL /* 2^53 - 1 */

/* An integer in [lo, hi], hi and -lo capped at JR_INTEGER_MAX: a larger
 * one is refused, not rounded to another. */
int jr_integer(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
               int64_t lo, int64_t hi, int64_t *out);
/* A non-empty string. */
int jr_string(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
              const char **out);
/* An array of exactly n finite numbers. */
int jr_numbers(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
               int n, double *out);
/* One of the strings of the NULL-terminated list names; *out its index. */
int jr_choice(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
              const char *const *names, int *out);
/* An array with at least min_count elements. */
int jr_array(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
             int min_count, const cJSON **out, int *count);
/* An object. */
int jr_object(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
              const cJSON **out);

/* Checks the value item itself (already fetched) at path: a finite number. */
int jr_item_number(jr_t *jr, const cJSON *item, const char *path, double *out);

#endif
