#ifndef _POSIX_C_SOURCE /* open, fstat, fdopen */
#define _POSIX_C_SOURCE 200809L
#endif
#include "jsonread.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int jr_fail(jr_t *jr, const char *path, const char *fmt, ...) {
  char what[3072];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(what, sizeof what, fmt, ap);
  va_end(ap);
  if (path != NULL && path[0] != '\0') {
    snprintf(jr->message, sizeof jr->message, "%s: %s: %s", jr->file, path, what);
  } else {
    snprintf(jr->message, sizeof jr->message, "%s: %s", jr->file, what);
  }
  return -1;
}

/* Marks a path cut short by the buffer with "..." at its end. */
static void mark_truncated(char out[JR_PATH_MAX], int written) {
  if (written < 0 || written >= JR_PATH_MAX) memcpy(out + JR_PATH_MAX - 4, "...", 4);
}

void jr_key(char out[JR_PATH_MAX], const char *parent, const char *key) {
  int n;
  if (parent == NULL || parent[0] == '\0') {
    n = snprintf(out, JR_PATH_MAX, "%s", key);
  } else {
    n = snprintf(out, JR_PATH_MAX, "%s.%s", parent, key);
  }
  mark_truncated(out, n);
}

void jr_index(char out[JR_PATH_MAX], const char *parent, int index) {
  mark_truncated(out, snprintf(out, JR_PATH_MAX, "%s[%d]", parent, index));
}

const char *jr_describe(const cJSON *item, char *buf, size_t size) {
  if (item == NULL) {
    snprintf(buf, size, "nothing");
  } else if (cJSON_IsNumber(item)) {
    snprintf(buf, size, "the number %g", item->valuedouble);
  } else if (cJSON_IsString(item)) {
    snprintf(buf, size, "the string \"%.40s%s\"", item->valuestring,
             strlen(item->valuestring) > 40 ? "..." : "");
  } else if (cJSON_IsArray(item)) {
    int n = cJSON_GetArraySize(item);
    snprintf(buf, size, "an array of %d element%s", n, n == 1 ? "" : "s");
  } else if (cJSON_IsObject(item)) {
    snprintf(buf, size, "an object");
  } else if (cJSON_IsBool(item)) {
    snprintf(buf, size, "%s", cJSON_IsTrue(item) ? "true" : "false");
  } else if (cJSON_IsNull(item)) {
    snprintf(buf, size, "null");
  } else {
    snprintf(buf, size, "an invalid value");
  }
  return buf;
}

const cJSON *jr_get(const cJSON *object, const char *key) {
  if (!cJSON_IsObject(object)) return NULL;
  const cJSON *item;
  cJSON_ArrayForEach(item, object) {
    if (item->string != NULL && strcmp(item->string, key) == 0) return item;
  }
  return NULL;
}

int jr_check_object(jr_t *jr, const cJSON *item, const char *path, const char *const *allowed) {
  char buf[96];
  if (!cJSON_IsObject(item)) {
    return jr_fail(jr, path, "expected an object, found %s", jr_describe(item, buf, sizeof buf));
  }
  const cJSON *member;
  cJSON_ArrayForEach(member, item) {
    char at[JR_PATH_MAX];
    jr_key(at, path, member->string);
    int known = 0;
    for (const char *const *a = allowed; *a != NULL; ++a) known = known || strcmp(*a, member->string) == 0;
    if (!known) {
      char list[1024] = "";
      size_t used = 0;
      for (const char *const *a = allowed; *a != NULL && used < sizeof list; ++a) {
        int n = snprintf(list + used, sizeof list - used, "%s\"%s\"", a == allowed ? "" : ", ", *a);
        if (n > 0) used += (size_t)n;
      }
      return jr_fail(jr, at, "unknown field (expected one of %s)", list);
    }
    for (const cJSON *other = item->child; other != member; other = other->next) {
      if (strcmp(other->string, member->string) == 0) return jr_fail(jr, at, "given twice");
    }
  }
  return 0;
}

/* Fetches object.key; fails if it is missing and required. Returns 1 if present. */
static int fetch(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
                 const cJSON **item, char at[JR_PATH_MAX]) {
  jr_key(at, path, key);
  *item = jr_get(object, key);
  if (*item == NULL) return required ? jr_fail(jr, at, "missing (required)") : 0;
  return 1;
}

int jr_item_number(jr_t *jr, const cJSON *item, const char *path, double *out) {
  char buf[96];
  if (item == NULL || !cJSON_IsNumber(item)) {
    return jr_fail(jr, path, "expected a number, found %s", jr_describe(item, buf, sizeof buf));
  }
  if (!isfinite(item->valuedouble)) return jr_fail(jr, path, "expected a finite number");
  *out = item->valuedouble;
  return 1;
}

int jr_number(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
              double *out) {
  const cJSON *item;
  char at[JR_PATH_MAX];
  int r = fetch(jr, object, path, key, required, &item, at);
  if (r <= 0) return r;
  return jr_item_number(jr, item, at, out);
}

int jr_positive(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
                double *out) {
  double v = 0.0;
  int r = jr_number(jr, object, path, key, required, &v);
  if (r <= 0) return r;
  if (!(v > 0.0)) {
    char at[JR_PATH_MAX];
    jr_key(at, path, key);
    return jr_fail(jr, at, "is %g; it must be > 0", v);
  }
  *out = v;
  return 1;
}

int jr_integer(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
               int64_t lo, int64_t hi, int64_t *out) {
  const cJSON *item;
  char at[JR_PATH_MAX], buf[96];
  int r = fetch(jr, object, path, key, required, &item, at);
  if (r <= 0) return r;
  double v = item != NULL && cJSON_IsNumber(item) ? item->valuedouble : (double)NAN;
  if (hi > JR_INTEGER_MAX) hi = JR_INTEGER_MAX;
  if (lo < -JR_INTEGER_MAX) lo = -JR_INTEGER_MAX;
  if (isfinite(v) && v == floor(v) && fabs(v) > (double)JR_INTEGER_MAX) {
    return jr_fail(jr, at, "is %.17g or a neighbour that rounds to it: a JSON integer is read as a double, "
                   "exact only up to 2^53 - 1; expected an integer from %lld to %lld", v, (long long)lo, (long long)hi);
  }
  /* The bounds are compared as integers (v is below 2^53 here). */
  if (!isfinite(v) || v != floor(v) || (int64_t)v < lo || (int64_t)v > hi) {
    return jr_fail(jr, at, "expected an integer from %lld to %lld, found %s", (long long)lo,
                   (long long)hi, jr_describe(item, buf, sizeof buf));
  }
  *out = (int64_t)v;
  return 1;
}

int jr_string(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
              const char **out) {
  const cJSON *item;
  char at[JR_PATH_MAX], buf[96];
  int r = fetch(jr, object, path, key, required, &item, at);
  if (r <= 0) return r;
  if (item == NULL || !cJSON_IsString(item) || item->valuestring[0] == '\0') {
    return jr_fail(jr, at, "expected a non-empty string, found %s", jr_describe(item, buf, sizeof buf));
  }
  *out = item->valuestring;
  return 1;
}

int jr_numbers(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
               int n, double *out) {
  const cJSON *item;
  char at[JR_PATH_MAX], buf[96];
  int r = fetch(jr, object, path, key, required, &item, at);
  if (r <= 0) return r;
  if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) != n) {
    return jr_fail(jr, at, "expected an array of %d numbers, found %s", n,
                   jr_describe(item, buf, sizeof buf));
  }
  int i = 0;
  const cJSON *e;
  cJSON_ArrayForEach(e, item) {
    char e_at[JR_PATH_MAX];
    jr_index(e_at, at, i);
    if (jr_item_number(jr, e, e_at, &out[i]) < 0) return -1;
    ++i;
  }
  return 1;
}

int jr_choice(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
              const char *const *names, int *out) {
  const cJSON *item;
  char at[JR_PATH_MAX], buf[96];
  int r = fetch(jr, object, path, key, required, &item, at);
  if (r <= 0) return r;
  if (cJSON_IsString(item)) {
    for (int i = 0; names[i] != NULL; ++i) {
      if (strcmp(names[i], item->valuestring) == 0) {
        *out = i;
        return 1;
      }
    }
  }
  char list[512] = "";
  size_t used = 0;
  for (int i = 0; names[i] != NULL && used < sizeof list; ++i) {
    int w = snprintf(list + used, sizeof list - used, "%s\"%s\"", i == 0 ? "" : ", ", names[i]);
    if (w > 0) used += (size_t)w;
  }
  return jr_fail(jr, at, "expected one of %s, found %s", list, jr_describe(item, buf, sizeof buf));
}

int jr_array(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
             int min_count, const cJSON **out, int *count) {
  const cJSON *item;
  char at[JR_PATH_MAX], buf[96];
  int r = fetch(jr, object, path, key, required, &item, at);
  if (r <= 0) return r;
  if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) < min_count) {
    return jr_fail(jr, at, "expected an array of at least %d element%s, found %s", min_count,
                   min_count == 1 ? "" : "s", jr_describe(item, buf, sizeof buf));
  }
  *out = item;
  *count = cJSON_GetArraySize(item);
  return 1;
}

int jr_object(jr_t *jr, const cJSON *object, const char *path, const char *key, int required,
              const cJSON **out) {
  const cJSON *item;
  char at[JR_PATH_MAX], buf[96];
  int r = fetch(jr, object, path, key, required, &item, at);
  if (r <= 0) return r;
  if (!cJSON_IsObject(item)) {
    return jr_fail(jr, at, "expected an object, found %s", jr_describe(item, buf, sizeof buf));
  }
  *out = item;
  return 1;
}

/* A regular file only: the open of a FIFO with no writer blocked forever
 * (O_NONBLOCK returns at once, then fstat refuses it), and /dev/zero was
 * read to 1 GiB before it was refused. */
static int read_file(jr_t *jr, const char *path, char **out) {
  int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return jr_fail(jr, "", "cannot open: %s", strerror(errno));
  struct stat st;
  const char *why = fstat(fd, &st) != 0 ? strerror(errno) : S_ISREG(st.st_mode) ? NULL : "not a regular file";
  if (why == NULL && st.st_size >= (off_t)1 << 30) why = "larger than 1 GiB; not a scene";
  FILE *f = why == NULL ? fdopen(fd, "rb") : NULL;
  if (f == NULL) {
    if (why == NULL) why = strerror(errno);
    close(fd);
    return jr_fail(jr, "", "cannot read: %s", why);
  }
  size_t cap = 1 << 16, len = 0;
  char *text = malloc(cap);
  for (;;) {
    if (text == NULL) {
      fclose(f);
      return jr_fail(jr, "", "out of memory");
    }
    len += fread(text + len, 1, cap - len - 1, f);
    if (ferror(f)) {
      free(text);
      fclose(f);
      return jr_fail(jr, "", "cannot read: %s", strerror(errno));
    }
    if (feof(f)) break;
    if (cap >= (size_t)1 << 30) {
      free(text);
      fclose(f);
      return jr_fail(jr, "", "larger than 1 GiB; not a scene");
    }
    char *bigger = realloc(text, cap * 2);
    if (bigger == NULL) free(text);
    text = bigger;
    cap *= 2;
  }
  fclose(f);
  text[len] = '\0';
  if (strlen(text) != len) {
    free(text);
    return jr_fail(jr, "", "contains a NUL byte; not a JSON text");
  }
  *out = text;
  return 0;
}

/* How many arrays and objects are open at end (strings skipped). */
static long nesting_at(const char *text, const char *end) {
  long depth = 0;
  bool in_string = false;
  for (const char *p = text; p < end && *p != '\0'; ++p) {
    if (in_string) {
      if (*p == '\\' && p[1] != '\0') ++p;
      else if (*p == '"') in_string = false;
    } else if (*p == '"') {
      in_string = true;
    } else if (*p == '[' || *p == '{') {
      ++depth;
    } else if (*p == ']' || *p == '}') {
      --depth;
    }
  }
  return depth;
}

/* "<file>:<line>:<column>: JSON syntax error near ..." for a parse failure at end. */
static int syntax_error(jr_t *jr, const char *text, const char *end) {
  int line = 1, column = 1;
  if (end == NULL) end = text;
  if (nesting_at(text, end) >= CJSON_NESTING_LIMIT) {
    /* Valid JSON, but cJSON stops parsing at that depth. */
    snprintf(jr->message, sizeof jr->message, "%s: arrays and objects are nested more than %d deep; the reader "
             "stops there (no scene needs that many)", jr->file, CJSON_NESTING_LIMIT);
    return -1;
  }
  for (const char *p = text; p < end && *p != '\0'; ++p) {
    if (*p == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  char near[24];
  size_t n = 0;
  for (const char *p = end; *p != '\0' && *p != '\n' && n < sizeof near - 1; ++p) near[n++] = *p;
  near[n] = '\0';
  snprintf(jr->message, sizeof jr->message,
           "%s:%d:%d: JSON syntax error%s%s%s (cJSON stops here; the mistake may be just before)",
           jr->file, line, column, n ? " near '" : " at the end of the file", near, n ? "'" : "");
  return -1;
}

int jr_parse(jr_t *jr, const char *text, cJSON **root) {
  const char *end = NULL;
  *root = cJSON_ParseWithOpts(text, &end, 1);
  if (*root == NULL) return syntax_error(jr, text, end);
  return 0;
}

int jr_load(jr_t *jr, const char *path, char **text, cJSON **root) {
  *text = NULL;
  *root = NULL;
  if (read_file(jr, path, text) < 0) return -1;
  return jr_parse(jr, *text, root);
}
