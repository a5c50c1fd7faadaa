/* Command-line helpers shared by hetinv-reconstruct, the experiment
 * programs and the reconstruction bench. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "recon.h"

/* The programs' error messages. Held in memory by recon_err_hold (MPI
 * ranks other than 0 of hetinv-reconstruct) until recon_err_release. */
static FILE *held;
static char *held_text;
static size_t held_size;
static bool erred;

void recon_err_hold(void) { held = open_memstream(&held_text, &held_size); /* NULL: stderr, as before */ }

FILE *recon_err(void) {
  erred = true;
  return held != NULL ? held : stderr;
}

bool recon_erred(void) { return erred; }

void recon_err_release(bool print) {
  if (held == NULL) return;
  fclose(held);
  held = NULL;
  if (print && held_size > 0) fwrite(held_text, 1, held_size, stderr);
  free(held_text);
  held_text = NULL;
}

int recon_parse_count(const char *prog, const char *opt, const char *text, int64_t lo, int64_t hi,
                      int64_t *out) {
  char *end = NULL;
  errno = 0;
  long long v = text ? strtoll(text, &end, 10) : 0;
  if (text == NULL || *text == '\0' || *end != '\0' || errno || v < lo || v > hi) {
    fprintf(recon_err(), "%s: %s: '%s' is not an integer from %lld to %lld\n", prog, opt, text ? text : "",
            (long long)lo, (long long)hi);
    return -1;
  }
  *out = v;
  return 0;
}

int recon_parse_real(const char *prog, const char *opt, const char *text, double lo, double hi, double *out) {
  char *end = NULL;
  double v = text ? strtod(text, &end) : 0.0;
  if (text == NULL || *text == '\0' || *end != '\0' || !(v >= lo && v <= hi)) {
    fprintf(recon_err(), "%s: %s: '%s' is not a number from %g to %g\n", prog, opt, text ? text : "", lo, hi);
    return -1;
  }
  *out = v;
  return 0;
}

int recon_parse_choice(const char *prog, const char *opt, const char *text, const char *const names[],
                       int *out) {
  for (int k = 0; text != NULL && names[k] != NULL; ++k) {
    if (strcmp(text, names[k]) == 0) {
      *out = k;
      return 0;
    }
  }
  fprintf(recon_err(), "%s: %s: '%s' is not one of", prog, opt, text ? text : "");
  for (int k = 0; names[k] != NULL; ++k) fprintf(recon_err(), "%s %s", k ? "," : "", names[k]);
  fputc('\n', recon_err());
  return -1;
}

int recon_parse_folder(const char *prog, const char *opt, const char *text, size_t reserve) {
  const size_t room = sizeof ((recon_scene_t *)NULL)->output - 1;
  if (text == NULL || *text == '\0') {
    fprintf(recon_err(), "%s: %s needs a folder\n", prog, opt);
    return -1;
  }
  if (strlen(text) + reserve > room) {
    fprintf(recon_err(), "%s: %s: the path is %zu bytes long; at most %zu here\n", prog, opt, strlen(text),
            room - reserve);
    return -1;
  }
  return 0;
}

uint64_t recon_fnv1a(uint64_t h, const void *data, size_t n) {
  const unsigned char *b = data;
  for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * UINT64_C(1099511628211);
  return h;
}

double recon_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

bool recon_failed_elsewhere(const hetinv_context_t *ctx) {
  int32_t origin = ctx != NULL ? hetinv_context_last_error_rank(ctx) : -1;
  return origin >= 0 && origin != hetinv_context_rank(ctx);
}

int recon_fail(const char *prog, const hetinv_context_t *ctx, const char *what) {
  if (recon_failed_elsewhere(ctx)) return 1;
  /* With ctx NULL (a failed hetinv_context_create) the thread's last message. */
  const char *message = hetinv_context_last_error_message(ctx);
  fprintf(recon_err(), "%s: %s: %s\n", prog, what, message[0] != '\0' ? message : "failed");
  return 1;
}
