/* Reconstruction support shared by hetinv-reconstruct and the paper's
 * experiment programs: a scene description (scene.c: defaults = the
 * built-in reduced Fig. 4 scene, and JSON), the imaging configurations of
 * the paper's Fig. 4 (imaging.c), simulated acquisition and measurement
 * files (acquire.c), acquisition from a render scene and the EXR files of
 * its rows (measured.c), the optimizer schedule with a progress line
 * (solve.c), and errors and output files (report.c). Public API only. */
#ifndef HETINV_RECON_H
#define HETINV_RECON_H

#include <stdbool.h>
#include <stdio.h>
#include <stdint.h>

#include <hetinv/hetinv.h>

#include "textfile.h"

/* The imaging configurations of the paper's Fig. 4 (section 6), and its
 * Fig. 5's front-, side- and back-lighting. */
typedef enum recon_config {
  RECON_PATHLENGTH = 1,       /* (1) pathlength-resolved, sensor at the source pixel and its two neighbours */
  RECON_STEADY = 2,           /* (2) steady-state orthographic cameras, several source orientations */
  RECON_PATHLENGTH_ANGLES = 3, /* (3) like (1), source orientations instead of neighbours */
  RECON_COMBINED = 4,         /* (4) (1) with its low-SNR values replaced by (2)'s steady state */
  RECON_PATHLENGTH_CAMERAS = 5 /* (2)'s cameras, pathlength-resolved: a source on the camera's face
                                * front-lights it, one on a side face side-lights it, one opposite
                                * back-lights it */
} recon_config_t;

enum { RECON_TRUTH_MIXTURE, RECON_TRUTH_SMOKE, RECON_TRUTH_VOL };
/* RESIDUAL: 1/variance of the loss's residual, the data's noise plus the
 * optimizer's render's Monte Carlo variance (simulated data only). */
enum { RECON_WEIGHT_VARIANCE, RECON_WEIGHT_RELATIVE, RECON_WEIGHT_UNIFORM, RECON_WEIGHT_RESIDUAL };
enum { RECON_CLIP_DATA, RECON_CLIP_RESIDUAL, RECON_CLIP_RESIDUAL_ABOVE };
enum { RECON_SNR_DATA, RECON_SNR_RESIDUAL };

/* Photons of the simulated data come from their own stream, so the
 * optimizer never reuses the paths that made its data. */
#define RECON_TRUTH_STREAM 40000
/* The independent render of acquisition.independent_errors. */
#define RECON_ERRORS_STREAM 41000

/* The JSON names of the weightings, optimizer methods and coordinates, in
 * the order of their enums; NULL-terminated. */
extern const char *const recon_weighting_names[];
extern const char *const recon_clip_errors_names[];
extern const char *const recon_snr_errors_names[];
extern const char *const recon_method_names[];
extern const char *const recon_coordinate_names[];

#define RECON_MAX_LEVELS 8
#define RECON_MAX_ANGLES 8
/* Layer-wise stages: with the levels' stages within HETINV_MAX_STAGES. */
#define RECON_MAX_LAYERS (HETINV_MAX_STAGES - RECON_MAX_LEVELS)
/* Most emitters (sources × orientations) of an imaging configuration. */
#define RECON_MAX_EMITTERS 65536

typedef struct recon_scene {
  /* Medium: a cube of side `size` (mm) with grid[0] × grid[1] × grid[2]
   * voxels; grid[1] = 1 is the paper's 2D cross-section (the section at
   * the middle of y, parameters constant along y). */
  double size;
  int32_t grid[3];
  double eta;
  /* Ground truth. */
  int truth_kind;
  uint64_t truth_seed;
  double truth_lo[3], truth_hi[3];
  char truth_vol[3][1024];
  /* Imaging. */
  recon_config_t config;
  int32_t pixels_per_voxel;     /* imaging pixels per voxel side */
  int32_t angle_count;          /* source orientations (degrees from the normal) */
  double angles[RECON_MAX_ANGLES];
  uint32_t source_faces;        /* bit f: sources on face f */
  uint32_t camera_faces;        /* bit f: a steady-state camera on face f */
  int32_t source_stride;        /* every n-th boundary pixel carries a source */
  double bin_width, max_pathlength; /* pathlength bins [0, max) of this width (mm) */
  double snr_threshold;         /* (4): values under this many read-noise deviations are replaced */
  /* Acquisition. */
  bool noise;
  hetinv_noise_model_t noise_model;
  int weighting;
  /* Values whose standard error exceeds value/min_snr are left out of the
   * loss and the bound (0: none). The simulated data are a Monte Carlo
   * render: a value few photons reach has a heavy-tailed error that its
   * batch means underestimate (docs/results/fig4.md), and a 1/σ² weight then
   * lets a handful of such values rule the loss and its gradient. */
  double min_snr;
  /* RECON_SNR_DATA: min_snr's test counts the data's standard error;
   * RECON_SNR_RESIDUAL: the residual's, the data's and the optimizer's
   * render's Monte Carlo error at sc->photons, so a value the data resolve
   * but each iteration's render does not is left out too (simulated data
   * only: the render's variance is the data's at their photons, scaled).
   * Worse at full size (docs/results/fig4.md): the render's noise averages
   * over iterations, the data's does not. */
  int min_snr_errors;
  /* The Monte Carlo part of each simulated value's standard error from a
   * second, independent render of the truth (same photons), so that a
   * value's weight does not depend on its own draw: with the same render,
   * a dim value whose draw missed the rare bright paths gets both a low
   * value and a small error, so the largest weights go to the values that
   * came out low. */
  bool independent_errors;
  /* A diagnostic of the weights' and the mask's own bias: the camera part
   * of each simulated value's standard error from its noise-free value's
   * expected electron count, not from the count recorded, and min_snr's
   * test on the noise-free value, so neither a weight nor the mask depends
   * on the camera's draw (otherwise a value recorded low gets a small error
   * and a large weight, and of the dim values the test keeps those
   * recorded high). With independent_errors the noise-free value is the
   * second render's, so that neither depends on the data's Monte Carlo
   * draw either, and pooled_errors pools at its values. A real camera
   * records only the count. */
  bool expected_camera_errors;
  /* The Monte Carlo part of each simulated value's variance pooled over
   * its neighbours (recon_pool_errors): the value times the variance-to-
   * value ratio of the 2·RECON_POOL_RADIUS + 1 values around it in its
   * bin's image, instead of the value's own batch estimate. A Monte Carlo
   * value's variance is its value times its paths' mean weight over the
   * photons (compound Poisson); that ratio changes slowly across an image,
   * while a dim value's own estimate, from its few paths, is heavy-tailed
   * and low exactly where the value came out low. The bound's variances
   * (recon_bound) are pooled the same way. */
  bool pooled_errors;
  char measurements[1024];      /* load these (EXR) instead of simulating; "" = simulate */
  /* Acquisition from files (measured.c): a render scene (its emitters,
   * sensors, pathlengths and rows; its medium for the grid, box and η
   * only) and the EXR files of its rows. "" = the imaging configurations
   * above. Paths resolved against the reconstruction scene's folder. */
  char render_scene[1024];
  char measured[1024];          /* folder of <row>.exr */
  char std_errors[1024];        /* folder of <row>_stderr.exr; "" = none */
  int gain_mode;                /* enum hetinv_gain_mode_id: unknown calibration gain(s) */
  double saturation;            /* values >= this are masked; +inf = none */
  size_t saturated;             /* set by recon_files_load: values at or above it */
  int32_t dark_rows;            /* set by recon_files_load: rows of zeros with zero errors, left out */
  bool has_box;                 /* the render scene's box (else the cube of `size`) */
  double box_min[3], box_max[3], eta_out;
  bool has_truth;               /* false (files without "truth"): no errors reported */
  int64_t truth_photons;        /* photons per emitter of the simulated measurements */
  /* Estimator during optimisation. */
  int64_t photons;
  int32_t batches;
  double loss_clip; /* Huber's clip in standard errors (HETINV_ESTIMATOR_LOSS_CLIP); 0: least squares */
  int loss_clip_errors; /* RECON_CLIP_DATA: the clip counts the data's standard errors; RECON_CLIP_RESIDUAL:
                         * the residual's (the data's and the render's Monte Carlo noise at sc->photons);
                         * RECON_CLIP_RESIDUAL_ABOVE: the residual's where the render is above the data,
                         * the data's below */
  /* Optimizer. */
  int method;
  int coordinates; /* enum hetinv_coordinates_id */
  int64_t iterations;           /* of the finest stage */
  double coarse_fraction;       /* iterations of each coarser stage, relative */
  int32_t minibatch;
  double epsilon, decay, learning_rate;
  double beta1, beta2;          /* Adam's decays */
  /* The ε schedules: ADADELTA's ε, and the other methods' learning_rate scaled by their ε over epsilon. */
  double epsilon_start;         /* the finest stage's ADADELTA ε at its start (0: epsilon throughout) */
  double coarse_epsilon_start;  /* each coarser stage's ADADELTA ε at its start (0: epsilon throughout) */
  double settle_epsilon;        /* the finest stage's ADADELTA ε over its last settle_fraction (0: its own) */
  double settle_fraction;
  double settle_photons;        /* its photons, × photons (0: none; hetinv_stage_t.settle_photons) */
  int32_t average_window;       /* 0: half the finest stage's iterations, or its settling part */
  int32_t coarse_average_window; /* each coarse stage's hand-on window; 0: average_window's */
  double time_budget;
  double smoothness;            /* the smoothness prior's weight (HETINV_OPTIMIZER_SMOOTHNESS); 0: none */
  double multiscale;            /* the multi-scale step's weight (HETINV_OPTIMIZER_MULTISCALE); 0: none */
  double box_margin;            /* how far iterates may leave the bounds (HETINV_OPTIMIZER_BOX_MARGIN); 0: not */
  int32_t bound_spacing;        /* maps past the dense Fisher limit: the blocks' probe spacing (0: 2) */
  double bounds_lo[3], bounds_hi[3];
  double init[3];               /* uniform initial values */
  bool init_at_truth;           /* start at the truth instead (a diagnostic) */
  bool init_keyed;              /* init differs from the scene's default: cells key it */
  int32_t level_count;          /* multi-resolution: cells per axis of each stage */
  int32_t levels[RECON_MAX_LEVELS];
  int32_t layerwise_layers;     /* > 0: layer-wise stages first (Fig. 2b) */
  bool levels_keyed;            /* levels differ from the experiment's schedule: cells key them */
  bool stage_results;           /* write each stage but the last's hand-on: <output>/stage<n>_<param>.vol */
  /* Run. */
  uint64_t seed;
  int32_t threads;
  char output[1024];
  char name[128];
} recon_scene_t;

/* The reduced Fig. 4 scene's settings, which a scene file is read over. */
void recon_scene_default(recon_scene_t *scene);
/* The built-in scene hetinv-reconstruct runs without a scene file:
 * recon_scene_default plus the settings chosen on its own volumes alone
 * (its smoothness prior); a scene file is read over recon_scene_default. */
void recon_scene_builtin(recon_scene_t *scene);
/* Sets scene->output from printf-style arguments. Returns -1, leaving it
 * unchanged, when the path does not fit: output paths are never cut short
 * (a shortened folder would receive another folder's files). */
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
int recon_scene_set_output(recon_scene_t *scene, const char *fmt, ...);
/* Reads a JSON scene over the defaults; on failure writes a message naming
 * the field to msg and returns -1. */
int recon_scene_read(const char *path, recon_scene_t *scene, char *msg, size_t msg_size);
/* The same on text already read, as if from the file at path. */
int recon_scene_parse(const char *path, const char *text, recon_scene_t *scene, char *msg,
                      size_t msg_size);
/* Checks the values; -1 with a message on a bad one. */
int recon_scene_check(const recon_scene_t *scene, char *msg, size_t msg_size);

/* Pathlength bins of the transient configurations, as a double (it may be
 * huge before recon_scene_check() has seen the scene). */
double recon_bin_count(const recon_scene_t *scene);
/* Whether the configuration has cameras on its camera_faces: (2), (4) and
 * pathlength_cameras. */
bool recon_has_cameras(const recon_scene_t *scene);

/* Emitters, rows and values the configuration would make, computed (as
 * doubles, without overflow) from the scene alone, before building it. */
typedef struct recon_imaging_size {
  double emitters, rows, values;
} recon_imaging_size_t;
void recon_imaging_size(const recon_scene_t *scene, recon_imaging_size_t *size);

struct scene; /* a render scene (render/scene.h), for the acquisition from files */

/* What recon_imaging_build() made, as the render scene that makes the
 * same (preset.c writes it): an ideal beam from `origin` along `direction`;
 * an orthographic sensor on `face` looking along `direction`, pixels of
 * `pixel` from `origin` in face coordinates; a row (emitter, sensor) in
 * steady state or in the pathlength bins. */
typedef struct recon_emitter_spec {
  double origin[3], direction[3];
} recon_emitter_spec_t;
typedef struct recon_sensor_spec {
  int face;
  double direction[3], origin[2], pixel[2];
  int32_t width, height;
} recon_sensor_spec_t;
typedef struct recon_row_spec {
  int32_t emitter, sensor;
  bool bins;
} recon_row_spec_t;

/* The sampling functions and measurement set of a configuration. */
typedef struct recon_imaging {
  hetinv_measurements_t *set;
  hetinv_emitter_t **emitters;
  hetinv_sensor_t **sensors;
  int32_t emitter_count, sensor_count, capacity_e, capacity_s;
  hetinv_pathlength_t *steady, *bins;
  int32_t rows_pathlength;      /* rows of configuration (1)/(3) come first */
  /* The same as a description (simulated configurations only; parallel
   * to emitters, sensors and the set's rows). */
  recon_emitter_spec_t *emitter_specs;
  recon_sensor_spec_t *sensor_specs;
  recon_row_spec_t *row_specs;
  int32_t row_count, capacity_r;
  int32_t bin_count;
  double bin_width;
  /* Acquisition from files: the render scene owning the sampling functions,
   * and its release (a pointer, so that the simulated path does not link
   * the render scene reader). */
  struct scene *files;
  void (*files_release)(struct scene *files);
} recon_imaging_t;

/* Builds the configuration's set for a medium of the scene's box and η. */
hetinv_result_t recon_imaging_build(hetinv_context_t *ctx, const hetinv_medium_t *medium,
                                    const recon_scene_t *scene, recon_imaging_t *out);
void recon_imaging_release(recon_imaging_t *im);

/* The medium of the scene, uncommitted, filled with `values` (3 numbers). */
hetinv_result_t recon_medium_create(hetinv_context_t *ctx, const recon_scene_t *scene,
                                    hetinv_medium_t **out);
/* The ground truth of the scene, committed. */
hetinv_result_t recon_truth_create(hetinv_context_t *ctx, const recon_scene_t *scene,
                                   hetinv_medium_t **out);

/* Renders the truth, applies the noise model row by row (one exposure per
 * row), sets values, errors, weights and (configuration 4) the mask. */
hetinv_result_t recon_simulate(hetinv_context_t *ctx, const recon_scene_t *scene,
                               const hetinv_medium_t *truth, recon_imaging_t *im);
/* Measurement files: one EXR row of value_count pixels, channels "value",
 * "std_error", "weight", "mask", and attributes naming the layout. */
hetinv_result_t recon_measurements_write(hetinv_context_t *ctx, const recon_imaging_t *im,
                                         const char *path);
/* Whether any of the set's clip scales differs from 1. */
bool recon_has_clip_scales(const hetinv_measurements_t *set);
hetinv_result_t recon_measurements_read(hetinv_context_t *ctx, recon_imaging_t *im,
                                        const char *path, char *msg, size_t msg_size);

/* Acquisition from files: reads sc->render_scene, takes the grid, box and
 * η from it (never its medium's values), builds its measurement set in im
 * and reads every row's values from <measured>/<row>.exr (and standard
 * errors from <std_errors>/<row>_stderr.exr), checked: a missing file, a
 * wrong channel count or pixel size, a non-finite value get a message
 * naming the file, the channel and the row. 0, or -1 after a message. */
int recon_files_load(hetinv_context_t *ctx, recon_scene_t *sc, recon_imaging_t *im, char *msg,
                     size_t msg_size);

/* Writes a simulated scene as the files every program reads (preset.c):
 * <dir>/render.json, the render scene of its acquisition (im's emitters,
 * sensors, pathlengths and rows; the truth as medium, photons, seed and
 * stream of the simulated render), <dir>/truth_<param>.vol, and
 * <dir>/reconstruct.json, the reconstruction from <dir>/data, the folder
 * hetinv-render writes that scene's rows to, with the scene's estimator
 * and optimizer. 0, or -1 with "<file>: <reason>" in msg. */
int recon_preset_write(hetinv_context_t *ctx, const recon_scene_t *scene, const hetinv_medium_t *truth, const recon_imaging_t *im,
                       const char *dir, char *msg, size_t msg_size);

/* The pooling of recon_scene_t.pooled_errors for one row of values laid
 * out bin-major (pixels × bins): mc, the standard errors of the Monte
 * Carlo values clean, replaced in place. HETINV_ERROR_OUT_OF_MEMORY
 * leaves mc as it was. */
#define RECON_POOL_RADIUS 4
hetinv_result_t recon_pool_errors(const double *clean, double *mc, int32_t pixels, int32_t bins);
/* Loss weights 1/s² from values and standard errors: s = the standard
 * error (variance), sqrt(se² + render_var) (residual; render_var the
 * variance of the optimizer's render of each value, NULL: 0),
 * max(|value|, 10⁻³·peak) (relative) or 1 (uniform). */
void recon_set_weights(int weighting, const double *v, const double *se, const double *render_var, double *w,
                       size_t n);

/* Clears mask[i] where v[i] < min_snr·se[i] (nothing if min_snr is 0). */
void recon_mask_unresolved(const double *v, const double *se, uint8_t *mask, size_t n, double min_snr);

/* The run's estimator settings: the scene's photons, batches, loss clip
 * and gain mode (what recon_solve() renders and differentiates with). */
hetinv_result_t recon_estimator_configure(hetinv_estimator_t *estimator, const recon_scene_t *scene);

/* Runs the scene's schedule from its uniform initial medium, writing
 * <output>/checkpoint.bin as it goes and <output>/loss.csv at the end. With
 * `resume`, continues from the checkpoint if it exists. `quiet` suppresses
 * the progress line. On success *out holds the recovery and *seconds the
 * optimisation time; on failure msg receives "<what or file>: <reason>". */
hetinv_result_t recon_solve(hetinv_context_t *ctx, const recon_scene_t *scene,
                            recon_imaging_t *im, bool resume, bool quiet,
                            hetinv_medium_t **out, double *seconds, char *msg, size_t msg_size);

/* Relative errors |x̂ − x| / x over the voxels, per parameter; with
 * has_bound, also the mean predicted relative standard deviation (bound.c),
 * achieved/bound = mean error / mean bound, and per voxel error / its own
 * bound: the largest, and how many of the `bounded` voxels (finite bound)
 * are above 2 (an efficient unbiased recovery has about 4.6 % of them
 * there by chance: P(|z| > 2)). */
typedef struct recon_errors {
  double mean[3], max[3];
  bool has_bound;
  double bound_mean[3], achieved_over_bound[3];
  double max_over_bound[3];
  double rms_over_bound[3]; /* root mean square of error / bound: about 1 if efficient */
  size_t over_2x_bound[3], bounded[3];
} recon_errors_t;
void recon_errors(const hetinv_medium_t *truth, const hetinv_medium_t *recovered, recon_errors_t *e);

/* Prints "<prog>: K of N values in the loss" and what min_snr's test left
 * out (the measurement set's mask, after the acquisition). */
void recon_print_in_loss(const char *prog, const recon_scene_t *scene, const recon_imaging_t *im);

/* Writes recovered_<param>.vol, maps.exr and maps_<param>.png (truth beside
 * recovery) and errors.csv into the scene's output directory (with truth
 * NULL: the recovery alone, no truth_*.vol, no errors.csv); on failure
 * msg receives "<file>: <reason>" (the library's message for its writers). */
hetinv_result_t recon_write_outputs(hetinv_context_t *ctx, const recon_scene_t *scene,
                                    const hetinv_medium_t *truth,
                                    const hetinv_medium_t *recovered, const recon_errors_t *errors,
                                    char *msg, size_t msg_size);

/* Reads a stored recovery, <scene->output>/recovered_<param>.vol, into a
 * committed medium of the scene's grid; on failure msg receives
 * "<file>: <reason>". */
hetinv_result_t recon_read_recovery(hetinv_context_t *ctx, const recon_scene_t *scene, hetinv_medium_t **out,
                                    char *msg, size_t msg_size);


/* Command-line helpers (cli.c). recon_parse_count: an integer option in
 * [lo, hi], or -1 after a message "<prog>: <opt>: '<text>' is not ...".
 * recon_now: monotonic seconds. recon_fail: prints "<prog>: <what>: " and
 * the context's last error message (ctx may be NULL); returns 1. Under MPI
 * it prints nothing where recon_failed_elsewhere(ctx): the rank the
 * failure arose on prints it, so it is printed once. */
int recon_parse_count(const char *prog, const char *opt, const char *text, int64_t lo, int64_t hi,
                      int64_t *out);
/* The same for a real number in [lo, hi] (NaN is refused). */
int recon_parse_real(const char *prog, const char *opt, const char *text, double lo, double hi, double *out);
/* The same for one of the NULL-terminated names (*out: its index). */
int recon_parse_choice(const char *prog, const char *opt, const char *text, const char *const names[],
                       int *out);
/* A folder option (-o DIR): refused, after a message naming the option and
 * the path's length, when the path and the `reserve` bytes the program
 * appends to it (its sub-folders) would not fit a scene's output. */
int recon_parse_folder(const char *prog, const char *opt, const char *text, size_t reserve);
/* FNV-1a of n bytes, continuing from h (start: RECON_FNV_OFFSET): the
 * programs' fingerprints of arrays and arguments (not a library hash). */
#define RECON_FNV_OFFSET UINT64_C(14695981039346656037)
uint64_t recon_fnv1a(uint64_t h, const void *data, size_t n);
double recon_now(void);
int recon_fail(const char *prog, const hetinv_context_t *ctx, const char *what);
bool recon_failed_elsewhere(const hetinv_context_t *ctx);
/* Where a program writes its error messages: stderr, or after
 * recon_err_hold() a buffer in memory that recon_err_release(print) writes
 * to stderr or drops. Under MPI most failures are every rank's alike (a
 * damaged checkpoint, a scene's error): ranks other than 0 hold theirs,
 * and only the lowest rank that wrote one (recon_erred) prints, so each
 * failure is printed once, by the first rank that had it. */
FILE *recon_err(void);
void recon_err_hold(void);
bool recon_erred(void);
void recon_err_release(bool print);

/* The Cramér–Rao bound of the configuration at a medium, the truth or,
 * from measured files without one, the recovery (bound.c): per voxel and
 * parameter the predicted relative standard deviation sd/value of any
 * unbiased estimate (hetinv_estimator_crb with an identity map of all
 * three parameters), under the scene's noise model at the clean values
 * plus the simulated data's render error, or from files the given
 * standard errors. rel: +inf where nothing reaches the voxel, NaN if the
 * estimated Fisher matrix is not positive definite. */
#define RECON_LOCAL_RADII 4 /* 0 to 3: at most 3·7³ = 1029 entries per window */
typedef struct recon_bound {
  bool done;
  bool at_recovery; /* evaluated at the recovery, not at the truth */
  int32_t positive_definite;
  double *rel[3], *rel_se[3];       /* per voxel (linear order) */
  double *lower[3];                  /* sqrt(1/F_kk)/value: a lower bound of rel */
  double mean[3], median[3], max[3]; /* over the finite ones */
  double se_mean[3];                 /* mean of their jackknife errors */
  double lower_mean[3];              /* mean of the finite lower bounds */
  size_t infinite[3], undefined[3];
  int64_t photons;
  int32_t replicates;
  double seconds;
  /* Only where F̂ is not positive definite: the local bound
   * (hetinv_fisher_local_crb) at radii 0 .. local_radii − 1, relative.
   * A window whose F̂ is not positive definite leaves its voxel
   * undetermined; past some radius most are, so the figure to quote is
   * local_best's. */
  int32_t local_radii;
  int32_t local_best; /* the largest radius with no more undetermined voxels than radius 0 */
  double *local[3];   /* per voxel at local_best */
  /* per voxel at each radius 0 .. local_radii − 1 (NaN where that radius's
   * window is not positive definite), for a voxel-by-voxel look at where
   * the windows stop being determined; only from the dense F̂ */
  double *local_at[RECON_LOCAL_RADII][3];
  /* > 0: the map was past HETINV_FISHER_MAX_ENTRIES, and local (radius 0)
   * comes from F's blocks (hetinv_estimator_fisher_blocks) at this spacing;
   * rel is NaN. */
  int32_t spacing;
  size_t entries;
  double local_mean[RECON_LOCAL_RADII][3], local_max[RECON_LOCAL_RADII][3];
  size_t local_undefined[RECON_LOCAL_RADII][3];
} recon_bound_t;
hetinv_result_t recon_bound_compute(hetinv_context_t *ctx, const recon_scene_t *scene,
                                    const hetinv_medium_t *truth, recon_imaging_t *im,
                                    int64_t photons, int32_t replicates, recon_bound_t *out);
void recon_bound_release(recon_bound_t *b);
/* The summary table (mean, median, max per parameter). */
void recon_bound_print(const recon_bound_t *b, FILE *f);
/* <output>/bound.exr (bound, its standard error and the lower bound per
 * parameter; with a local bound also bound_local_<param>, local_best's,
 * and bound_local_r<N>_<param> for each radius N computed) and
 * <output>/bound_<param>.png. */
hetinv_result_t recon_bound_write(hetinv_context_t *ctx, const recon_scene_t *scene,
                                  const hetinv_medium_t *truth, const recon_bound_t *b);
/* Computes, prints (root) and writes (root) the bound (past
 * HETINV_FISHER_MAX_ENTRIES entries the local one at radius 0); with
 * several MPI ranks it is skipped with a note (b->done false). 0, or 1
 * after a message. */
int recon_bound_run(const char *prog, hetinv_context_t *ctx, const recon_scene_t *scene,
                    const hetinv_medium_t *at, recon_imaging_t *im, int64_t photons,
                    int32_t replicates, bool root, bool at_recovery, recon_bound_t *b);
/* The per-voxel relative bound of parameter p that errors are judged by:
 * the local one where only it exists (b->spacing > 0), else rel. */
static inline const double *recon_bound_per_voxel(const recon_bound_t *b, int p) {
  return b->spacing > 0 ? b->local[p] : b->rel[p];
}
/* An efficient unbiased recovery against a worst-voxel target max_rel,
 * each voxel's relative error taken as normal with its bound as standard
 * deviation (efficient.c): over_max[p], the expected number of voxels of
 * parameter p whose error exceeds max_rel (exact for normal errors, by
 * linearity); pass, the product over every voxel of the three parameters
 * of P(|error| <= max_rel). Correlated normal errors pass with at least
 * that probability (Sidak's inequality), so pass is a lower bound of an
 * efficient recovery's odds of meeting the target; pass_at_most, the
 * hardest voxel's P(|error| <= max_rel), an upper bound. Where the bound
 * is the local one (a lower bound of the standard deviation), the figures
 * lean the other way: the data predict at least these misses. NaN without
 * a bound. */
typedef struct recon_efficient {
  double over_max[3];
  double pass, pass_at_most;
} recon_efficient_t;
void recon_bound_efficient(const recon_bound_t *b, size_t voxels, double max_rel, recon_efficient_t *out);
/* Fills e's bound columns from b and the recovery (no-op if b was not
 * computed); with only the local bound (b->spacing > 0), from it. */
void recon_bound_attach(const recon_bound_t *b, const hetinv_medium_t *truth,
                        const hetinv_medium_t *recovered, recon_errors_t *e);

#endif
