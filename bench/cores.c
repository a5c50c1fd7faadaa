/* sched_setaffinity and the CPU_* macros are GNU extensions. */
#define _GNU_SOURCE
#include "cores.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#ifdef __linux__
#include <sched.h>

static cpu_set_t g_allowed; /* the thread's CPUs before any pinning */
static bool g_have_allowed = false;

int cores_pick(int cpu[], int max) {
  if (sched_getaffinity(0, sizeof g_allowed, &g_allowed) != 0) return 0;
  g_have_allowed = true;
  int found = 0;
  for (int c = 0; c < CPU_SETSIZE && found < max; ++c) {
    if (CPU_ISSET(c, &g_allowed)) cpu[found++] = c;
  }
  return found;
}

static bool set_affinity(const cpu_set_t *set, const char *what) {
  if (sched_setaffinity(0, sizeof *set, set) == 0) return true;
  fprintf(stderr, "hetinv-bench: cannot %s: %s\n", what, strerror(errno));
  return false;
}

bool cores_pin(int cpu) {
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(cpu, &one);
  return set_affinity(&one, "pin the thread to one CPU");
}

bool cores_release(void) {
  return !g_have_allowed || set_affinity(&g_allowed, "restore the thread's CPUs");
}

#else

int cores_pick(int cpu[], int max) {
  (void)cpu;
  (void)max;
  return 0;
}

bool cores_pin(int cpu) {
  (void)cpu;
  return false;
}

bool cores_release(void) { return true; }

#endif
