/* Each core's one-thread speed, measured apart: the calling thread pinned
 * to one CPU, then let go again. On the shared two-core machines these
 * benchmarks run on, each core's speed drifts by up to 30 % within minutes,
 * so a one-thread run that lands on whichever core is fast at the moment
 * is no reference for a two-thread run, which uses both: the reference is
 * the mean speed of the two cores, each measured in the same round.
 * Linux only; elsewhere cores_pick finds none and nothing is pinned. */
#ifndef HETINV_BENCH_CORES_H
#define HETINV_BENCH_CORES_H

#include <stdbool.h>

/* The first `max` CPUs this process may run on, in cpu[0..]; returns how
 * many it found (0 where the platform cannot pin). Remembers the calling
 * thread's CPU set for cores_release. */
int cores_pick(int cpu[], int max);

/* Pins the calling thread to CPU `cpu`; false (with a message on stderr)
 * if the system refuses. */
bool cores_pin(int cpu);

/* Lets the calling thread run on the CPU set cores_pick found again. */
bool cores_release(void);

#endif
