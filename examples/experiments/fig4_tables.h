/* hetinv-fig4's tables over the finished cells, each printed and written
 * to a CSV file in the run's folder; configurations are indexed 1..4. */
#ifndef FIG4_TABLES_H
#define FIG4_TABLES_H

#include <stdbool.h>
#include <stdint.h>

#include "verdict.h"

/* "(1) pathlength, neighbours", ...; [0] is empty. */
extern const char *const fig4_config_names[5];

/* Mean over volumes of the voxel mean / max over volumes of the voxel max
 * error: DIR/fig4_table.csv. */
int error_table(const char *out, bool full, int64_t volumes, const bool configs[5], double mean[5][3],
                double max[5][3], const double seconds[5]);
/* The bounds, with achieved/bound where error_mean is not NULL:
 * DIR/fig4_bound.csv. */
int bound_table(const char *out, int64_t volumes, const bool configs[5], double mean[5][3], double max[5][3],
                const int pd[5], const int local[5], const double seconds[5], double error_mean[5][3]);
/* The target per configuration and parameter, voxel by voxel:
 * DIR/fig4_target.csv. */
int target_table(const char *out, const bool configs[5], const bool have[5], double error_mean[5][3],
                 double bound_mean[5][3], const experiment_verdict_t verdict[5]);

#endif
