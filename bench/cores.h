/* Each core's one-thread speed, measured apart: the calling thread pinned
 * to one CPU, then let go again. On the shared two-core machines these
 * benchmarks run on, each core's speed drifts by up to 30 % within minutes,
 * so a one-thread run that lands on whichever core is fast at the moment
 * is no reference for a two-thread run, which uses both: the reference is
 * the mean speed of the two cores, each measured in the same round.
 * Linux only; elsewhere cores_pick_two finds none and nothing is pinned. */
#ifndef HETINV_BENCH_CORES_H
#define HETINV_BENCH_CORES_H

#include <stdbool.h>

/* The first two CPUs this process may run on, in cpu[0] and cpu[1]; false
 * if it may run on fewer (or the platform cannot pin). Remembers the
 * calling thread's CPU set for cores_release. */
bool cores_pick_two(int cpu[2]);

/* Pins the calling thread to CPU `cpu`; false (with a message on stderr)
 * if the system refuses. */
bool cores_pin(int cpu);

/* Lets the calling thread run on the CPU set cores_pick_two found again. */
bool cores_release(void);

#endif
