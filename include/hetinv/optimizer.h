/**
 * @file optimizer.h
 * @brief Appearance matching: stochastic gradient descent on the loss of
 *        Eq. (9) over a parameter vector π (see param.h).
 *
 * An optimizer holds one problem — a measurement set with its measured
 * values, weights and mask, and an initial medium — and a schedule of
 * stages. Each stage has a parameter map (multi-resolution: a coarse map
 * first, then finer ones; each stage starts from the previous stage's
 * result), optionally entries kept fixed and values left out (the
 * layer-wise procedure of the paper's Fig. 2(b), see
 * hetinv_optimizer_add_layerwise_stages()). An iteration:
 *  1. draws a minibatch of emitters (all rows of each; without replacement,
 *     from a counter-based stream keyed by the context's seed and the
 *     iteration, so it is reproducible);
 *  2. renders the minibatch and estimates the loss gradient from
 *     independent paths (hetinv_estimator_loss_gradient(), with the
 *     estimator's EPOCH set to the iteration so paths are fresh each time);
 *  3. takes a step of the chosen method and projects π onto its box.
 *
 * Methods: ADADELTA (Zeiler 2012, with the square roots; the default, as in
 * the paper's Algorithm 1), plain SGD, AdaGrad and Adam. Every method works
 * in scaled coordinates: entry k of π has a scale s_k, the width of its box
 * (or 1 when the box is unbounded), so one setting suits σ in mm⁻¹ and g
 * alike. The result is the average of the trailing iterates of the last
 * stage (Algorithm 1, line 9, over a trailing window; see
 * HETINV_OPTIMIZER_AVERAGE_WINDOW).
 *
 * Runs stop at the end of the schedule, at a time budget, or when the
 * progress callback asks; a stage ends after its iteration count or on a
 * loss plateau. With a checkpoint path set, the full state is written
 * atomically (temporary file, then rename) every few iterations and at the
 * end; hetinv_optimizer_resume() continues a run from such a file, and the
 * continuation is bitwise identical to an uninterrupted run.
 *
 * An optimizer belongs to one thread at a time. The set, the maps and the
 * sampling functions the set uses must outlive it.
 */
#ifndef HETINV_OPTIMIZER_H
#define HETINV_OPTIMIZER_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/context.h"
#include "hetinv/estimator.h"
#include "hetinv/export.h"
#include "hetinv/measurement.h"
#include "hetinv/medium.h"
#include "hetinv/param.h"
#include "hetinv/result.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Opaque optimizer handle. */
typedef struct hetinv_optimizer hetinv_optimizer_t;

/** A descent method: a value of enum hetinv_optimizer_method_id. */
typedef int32_t hetinv_optimizer_method_t;

/** Descent methods. Pinned values. */
enum hetinv_optimizer_method_id {
  /** ADADELTA: δ_k = sqrt(E[δ²]_k + ε_k) / sqrt(E[g²]_k) · g_k, with decay γ. */
  HETINV_METHOD_ADADELTA = 0,
  /** Plain SGD: δ_k = rate · s_k² · g_k (the loss's units matter). */
  HETINV_METHOD_SGD = 1,
  /** AdaGrad: δ_k = rate · s_k · g_k / sqrt(Σ g_k²). */
  HETINV_METHOD_ADAGRAD = 2,
  /** Adam: δ_k = rate · s_k · m̂_k / sqrt(v̂_k), with decays β1, β2. */
  HETINV_METHOD_ADAM = 3,
  HETINV_METHOD_COUNT_ = 4 /**< not a method: one past the last */
};

/** A tunable of the optimizer: a value of enum hetinv_optimizer_param_id. */
typedef int32_t hetinv_optimizer_param_t;

/** Optimizer tunables; see hetinv_optimizer_param_bounds(). Pinned values. */
enum hetinv_optimizer_param_id {
  /** The method, an enum hetinv_optimizer_method_id (default ADADELTA). */
  HETINV_OPTIMIZER_METHOD = 0,
  /** ADADELTA's decay rate γ (default 0.95; [0, 0.999999]). */
  HETINV_OPTIMIZER_DECAY = 1,
  /** ADADELTA's ε, relative: ε_k = (EPSILON · s_k)², so the first step
   *  moves an entry by EPSILON · s_k / sqrt(1 − DECAY) (about 4.5 EPSILON of
   *  its box width with the default DECAY). Once the gradient is mostly
   *  Monte Carlo noise the steps settle at a few EPSILON · s_k, so a
   *  smaller value gives a steadier result but a slower start
   *  (hetinv-reconstruct uses 0.003) (default 0.01; [1e-12, 1]). */
  HETINV_OPTIMIZER_EPSILON = 2,
  /** Step size of SGD, AdaGrad and Adam (default 0.01; [1e-300, 1e12]). A
   *  stage's ε schedule (hetinv_stage_t.epsilon_start, settle_epsilon)
   *  scales it by the schedule's ε over HETINV_OPTIMIZER_EPSILON, so the
   *  schedule means the same for every method. */
  HETINV_OPTIMIZER_LEARNING_RATE = 3,
  /** Adam's β1 (default 0.9; [0, 0.999999]). */
  HETINV_OPTIMIZER_BETA1 = 4,
  /** Adam's β2 (default 0.999; [0, 0.999999]). */
  HETINV_OPTIMIZER_BETA2 = 5,
  /** Emitters per iteration (default 0 = every emitter of the set; integer ≥ 0). */
  HETINV_OPTIMIZER_MINIBATCH = 6,
  /** Iterations of a stage that does not give its own count (default 100; integer ≥ 1). */
  HETINV_OPTIMIZER_ITERATIONS = 7,
  /** Wall-clock budget of the whole run in seconds (default 0 = none; ≥ 0).
   *  Time-limited runs are not reproducible, by nature. */
  HETINV_OPTIMIZER_TIME_BUDGET = 8,
  /** A stage ends early when the mean loss of the last PLATEAU_WINDOW
   *  iterations is not below (1 − PLATEAU_TOLERANCE) × the mean of the
   *  window before (default 0 = never; integer ≥ 0). */
  HETINV_OPTIMIZER_PLATEAU_WINDOW = 9,
  /** Relative decrease a plateau window must beat (default 0.01; [0, 1]). */
  HETINV_OPTIMIZER_PLATEAU_TOLERANCE = 10,
  /** The result averages the last AVERAGE_WINDOW iterates of the stage
   *  (default 20; integer in [1, 4096]; 1 returns the last iterate). */
  HETINV_OPTIMIZER_AVERAGE_WINDOW = 11,
  /** Iterations between checkpoints when a checkpoint path is set
   *  (default 10; integer ≥ 1). A checkpoint is also written when the run ends. */
  HETINV_OPTIMIZER_CHECKPOINT_INTERVAL = 12,
  /** The coordinates the method steps in, an enum hetinv_coordinates_id
   *  (default HETINV_COORDINATES_NATIVE). */
  HETINV_OPTIMIZER_COORDINATES = 13,
  /** Weight λ of an optional smoothness prior, in the loss's units (default
   *  0 = none, the loss of Eq. 9 alone; [0, 1e12]). The loss gains
   *  λ Σ_p ∫|∇u_p|², u_p = π_p / s_p over the stage's cells with the box
   *  taken as the unit cube: per pair of cells adjacent along axis a,
   *  λ (n_a² / N)(u_i − u_j)² (n_a cells along a, N cells in all), so a
   *  smooth field costs the same at every level of a multi-resolution
   *  schedule. Entries of different parameters are never coupled. A field
   *  that crosses its box once costs about λ. With weights 1/σ² the data's
   *  loss at the truth is about the number of values, more with the
   *  estimator's own Monte Carlo noise (Fig. 5's runs end near 8× it), so
   *  λ is chosen relative to the loss the progress callback reports. For voxels the data
   *  cannot split (thin media, deep voxels); it biases sharp features.
   *  Added in 0.2. */
  HETINV_OPTIMIZER_SMOOTHNESS = 14,
  /** Weight α of an optional multi-scale step (default 0 = none; [0, 100]).
   *  Before each step the gradient of every entry gains α times the mean
   *  gradient of its parameter over its block of cells at each coarser
   *  scale: blocks of 2, 4, 8, ... cells along each axis, up to the whole
   *  grid. A per-entry step (every method here) moves a field's smooth
   *  component only as fast as each entry's own gradient, which the
   *  estimator's noise dominates once the field is close; the blocks' means
   *  average that noise away and move such a component coherently. It is
   *  gradient descent in a pyramid of the stage's cells (a positive
   *  definite preconditioner), so it changes the path, not the loss or its
   *  minimum. Frozen entries neither move nor enter the means. Added in 0.2. */
  HETINV_OPTIMIZER_MULTISCALE = 15,
  /** How far the iterates may leave each parameter's box (default 0: not
   *  at all; [0, 1]), as a fraction m of its width: [lo − m·w, hi + m·w]
   *  natively, [lo·(hi/lo)^−m, hi·(hi/lo)^m] for an entry that moves in
   *  ln π (HETINV_COORDINATES_LOG), never below 0 for σa and σs nor past
   *  ±0.99 for g (unless the box itself reaches further). The averaged iterate (a stage's hand-on to the
   *  next, the result, hetinv_optimizer_get_pi averaged) is projected onto
   *  the box itself. Where the truth lies on or near a bound, iterates that
   *  wander about it are clipped on one side only, and their average lands
   *  inside the box, off the truth; free to cross the bound, they average
   *  to it. The renders in between see values outside the box, so the
   *  box's outer band must be physical: set it where a value beyond the
   *  box is only unlikely, not impossible. Added in 0.2. */
  HETINV_OPTIMIZER_BOX_MARGIN = 16,
  HETINV_OPTIMIZER_PARAM_COUNT_ = 17 /**< not a parameter: one past the last */
};

/** Coordinates of the descent: values of HETINV_OPTIMIZER_COORDINATES. Pinned values. */
enum hetinv_coordinates_id {
  /** Each π entry moves on its own: (σa, σs, g) as mapped. */
  HETINV_COORDINATES_NATIVE = 0,
  /** Where a cell's σs and g are both free, they move as (σs' = σs(1 − g), g):
   *  steady light mostly sees the reduced scattering σs' (similarity), so the
   *  loss is a narrow valley along σs(1 − g) = const in native coordinates,
   *  which a per-entry step crosses slowly; here the valley lies along g. The
   *  result, bounds, averaging and π stay native. */
  HETINV_COORDINATES_REDUCED = 1,
  /** Each π entry whose box is 0 < lo < hi < ∞ moves in ln π, its scale
   *  ln(hi / lo): a step changes it by a factor, so the step's noise floor
   *  (ε) is relative to the value, not to the box's width, and a value near
   *  the box's floor wanders no further in relative terms than one near its
   *  top. Other entries move natively. The result, bounds, averaging and π
   *  stay native. Added in 0.3. */
  HETINV_COORDINATES_LOG = 2,
  /** HETINV_COORDINATES_LOG and HETINV_COORDINATES_REDUCED together: where a
   *  cell's σs and g are both free they move as (ln σs', g), σs' = σs(1 − g),
   *  so a step changes the reduced scattering by a factor and the valley of
   *  steady light lies along g; every other entry with a positive bounded
   *  box moves in ln π. The result, bounds, averaging and π stay native.
   *  Added in 0.3. */
  HETINV_COORDINATES_LOG_REDUCED = 3,
  /** Where a cell's σa and σs are both free and their boxes positive and
   *  bounded, they move as (ln √(σa·σs), ln √(σa/σs)), every other entry as
   *  under HETINV_COORDINATES_LOG. Diffuse light is set mostly by the
   *  product (μeff² ≈ 3σa·σs(1 − g)), so in (ln σa, ln σs) the loss is a
   *  narrow valley along ln σa + ln σs = const, which a per-entry step
   *  crosses fast and follows slowly, trading one for the other; here the
   *  valley lies along the ratio's axis, whose step adapts to its own
   *  gradient. Both take the mean of the two boxes' ln(hi/lo) as their
   *  scale. Added in 0.2. */
  HETINV_COORDINATES_LOG_MEAN_RATIO = 4,
  HETINV_COORDINATES_COUNT_ = 5 /**< not a value: one past the last */
};

/** Why a run ended: a value of enum hetinv_stop_reason_id. */
typedef int32_t hetinv_stop_reason_t;

/** Why a run ended. Pinned values. */
enum hetinv_stop_reason_id {
  HETINV_STOP_NONE = 0,        /**< still running, or never run */
  HETINV_STOP_COMPLETED = 1,   /**< every stage ran to its end (count or plateau) */
  HETINV_STOP_TIME_BUDGET = 2, /**< the time budget ran out */
  HETINV_STOP_CALLBACK = 3     /**< the progress callback asked to stop */
};

/** Most stages of a schedule. Each stage keeps a copy of its masks (one
 *  byte per π entry and per measured value), so the schedule stays small. */
#define HETINV_MAX_STAGES 256

/**
 * @brief One stage of the schedule.
 *
 * The struct begins with its size: set @c size = sizeof(hetinv_stage_t).
 * Members are only ever added at the end; a caller built against an older
 * header passes its smaller size and the newer members read as 0.
 */
typedef struct hetinv_stage {
  size_t size;                    /**< sizeof(hetinv_stage_t), set by the caller */
  const hetinv_param_map_t *map;  /**< π of this stage; borrowed, must outlive the optimizer */
  int32_t iterations;             /**< iterations; 0 = HETINV_OPTIMIZER_ITERATIONS */
  const uint8_t *frozen;          /**< hetinv_param_map_size(map) bytes, non-zero = entry kept fixed; or NULL. Copied. */
  const uint8_t *value_mask;      /**< value_count bytes, 0 = value left out (ANDed with the set's mask); or NULL. Copied. */
  /** ADADELTA's ε at the start of this stage, relative as
   *  HETINV_OPTIMIZER_EPSILON (in [1e-12, 1]); it falls linearly to that
   *  tunable over the stage's first half and stays there: far moves early,
   *  then the tunable's small steps for the iterates the result averages.
   *  Under SGD, AdaGrad and Adam this and @c settle_epsilon scale
   *  HETINV_OPTIMIZER_LEARNING_RATE by their ε over the tunable's.
   *  0 = the tunable throughout. Added in 0.2. */
  double epsilon_start;
  /** The trailing iterates this stage's result averages (the next stage's
   *  start, or the run's result), at most HETINV_OPTIMIZER_AVERAGE_WINDOW
   *  (the averaging ring's length; a larger value acts as it); 0 = that
   *  tunable. A short stage under a long tunable window would otherwise
   *  hand on the mean of its whole path, its start included. Added in 0.2. */
  int32_t average_window;
  /** ADADELTA's ε over the stage's last @c settle_fraction of its
   *  iterations, relative as HETINV_OPTIMIZER_EPSILON (in [1e-12, 1]);
   *  0 = the stage's own ε there (a settling part of @c settle_photons
   *  alone). Large steps approach, small ones settle: a stochastic step's
   *  iterates scatter about a point that is off the loss's minimum
   *  by an amount that grows with the step where the loss is not
   *  quadratic, and averaging them does not remove that offset. With
   *  @c average_window 0 the stage's result averages its settling
   *  iterates (at most HETINV_OPTIMIZER_AVERAGE_WINDOW of them). Added in 0.2. */
  double settle_epsilon;
  /** The fraction of the stage's iterations, in (0, 1), that settle (at
   *  @c settle_epsilon, with @c settle_photons): the last
   *  round(settle_fraction × iterations).
   *  Required with @c settle_epsilon or @c settle_photons, 0 without
   *  both. Added in 0.2. */
  double settle_fraction;
  /** The estimator's photons per emitter over the settling part, as a
   *  multiple of its HETINV_ESTIMATOR_PHOTONS (rounded to a whole count;
   *  in [1, 1e6]); 0 = that count, without a settling part of its own. A Monte Carlo budget that grows
   *  as the step settles: the offset @c settle_epsilon describes shrinks
   *  with the gradient's noise as well as with the step, and more photons
   *  do not slow the approach a smaller step slows. The estimator's own
   *  tunable is left as it was. With this alone the settling part runs at
   *  the stage's ε. Added in 0.3. */
  double settle_photons;
} hetinv_stage_t;

/** The size of the first hetinv_stage_t (without @c epsilon_start and
 *  @c average_window), which hetinv_optimizer_add_stage() still accepts. */
#define HETINV_STAGE_SIZE_V1 (offsetof(hetinv_stage_t, value_mask) + sizeof(const uint8_t *))
/** The size of the second hetinv_stage_t (without @c settle_epsilon and
 *  @c settle_fraction), which hetinv_optimizer_add_stage() still accepts. */
#define HETINV_STAGE_SIZE_V2 (offsetof(hetinv_stage_t, settle_epsilon))
/** The size of the third hetinv_stage_t (without @c settle_photons), which
 *  hetinv_optimizer_add_stage() still accepts. */
#define HETINV_STAGE_SIZE_V3 (offsetof(hetinv_stage_t, settle_photons))

/**
 * @brief What the progress callback is told after every iteration.
 *
 * Begins with its size, so newer members can be added at the end.
 */
typedef struct hetinv_progress {
  size_t size;              /**< sizeof(hetinv_progress_t) of the library */
  int32_t stage;            /**< current stage (0-based) */
  int32_t stage_count;      /**< stages in the schedule */
  int64_t iteration;        /**< iterations done in all stages */
  int64_t stage_iteration;  /**< iterations done in this stage */
  int64_t stage_iterations; /**< the stage's iteration count */
  int64_t total_iterations; /**< iterations of the whole schedule (stages ending on a plateau count in full) */
  double loss;              /**< this iteration's loss, scaled to the whole set (minibatch loss × emitters / minibatch), plus the smoothness prior's value (HETINV_OPTIMIZER_SMOOTHNESS) */
  double step;              /**< root mean square of the step over the stage's entries, relative to their scales */
  double elapsed;           /**< seconds of optimisation (across resumes) */
} hetinv_progress_t;

/**
 * @brief Progress callback: called after every iteration.
 * @param progress the state after the iteration; valid during the call.
 * @param user the pointer given to hetinv_optimizer_set_progress().
 * @return 0 to go on; non-zero to stop the run (HETINV_STOP_CALLBACK).
 */
typedef int (*hetinv_progress_fn)(const hetinv_progress_t *progress, void *user);

/**
 * @brief Create an optimizer for a measurement set.
 * @param ctx the context (seed, allocator, errors).
 * @param set the measurement set with its measured values; borrowed: it must
 *        outlive the optimizer and not change while the optimizer exists.
 * @param initial a medium with the set's box and indices; copied. Its values
 *        start every free parameter and keep every other one.
 * @param[out] out receives the optimizer; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (empty set; initial of another box
 *         or indices than the set's);
 *         HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_optimizer_create(hetinv_context_t *ctx,
                                                   const hetinv_measurements_t *set,
                                                   const hetinv_medium_t *initial,
                                                   hetinv_optimizer_t **out);

/** @brief Destroy an optimizer and set @p *optimizer to NULL; NULL is a no-op. */
HETINV_API void hetinv_optimizer_destroy(hetinv_optimizer_t **optimizer);

/**
 * @brief Valid range of a tunable (integers are passed as doubles).
 * @param param the tunable.
 * @param[out] lo the inclusive lower bound; may be NULL.
 * @param[out] hi the inclusive upper bound; may be NULL.
 * @return HETINV_SUCCESS; HETINV_ERROR_OUT_OF_RANGE for an unknown tunable.
 */
HETINV_API hetinv_result_t hetinv_optimizer_param_bounds(hetinv_optimizer_param_t param,
                                                         double *lo, double *hi);

/**
 * @brief Set a tunable. Not allowed once a run has started (the state would
 *        no longer continue the same run).
 * @param optimizer the optimizer.
 * @param param the tunable.
 * @param value within hetinv_optimizer_param_bounds(); integers must be integral.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE
 *         (unknown tunable); HETINV_ERROR_INVALID_ARGUMENT (value);
 *         HETINV_ERROR_INVALID_STATE (run started).
 */
HETINV_API hetinv_result_t hetinv_optimizer_set_param(hetinv_optimizer_t *optimizer,
                                                      hetinv_optimizer_param_t param, double value);

/**
 * @brief Read a tunable.
 * @param optimizer the optimizer.
 * @param param the tunable.
 * @param[out] value receives it.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE.
 */
HETINV_API hetinv_result_t hetinv_optimizer_get_param(const hetinv_optimizer_t *optimizer,
                                                      hetinv_optimizer_param_t param,
                                                      double *value);

/** The widest finite box hetinv_optimizer_set_bounds() takes: its width is
 *  the entries' step scale, which the methods square. */
#define HETINV_OPTIMIZER_MAX_BOX_WIDTH 1e100

/**
 * @brief Box constraint of one physical parameter, applied to every π entry
 *        of that parameter by projection after each step.
 *
 * Defaults: σa, σs ∈ [0, +∞) and g ∈ [−0.99, 0.99]. The paper uses
 * σa, σs ∈ [1, 10] mm⁻¹ and g ∈ [0, 0.6]. Finite bounds also set the
 * entries' scales s_k = hi − lo. Not allowed once a run has started.
 * @param optimizer the optimizer.
 * @param param HETINV_PARAM_SIGMA_A, _SIGMA_S or _G.
 * @param lo the lower bound, within the parameter's domain (σ ≥ 0;
 *        −1 < g < 1), lo < hi.
 * @param hi the upper bound, within the domain; +∞ allowed for σ; a finite
 *        hi − lo at most HETINV_OPTIMIZER_MAX_BOX_WIDTH.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE
 *         (param); HETINV_ERROR_INVALID_ARGUMENT (bounds);
 *         HETINV_ERROR_INVALID_STATE (run started).
 */
HETINV_API hetinv_result_t hetinv_optimizer_set_bounds(hetinv_optimizer_t *optimizer,
                                                       hetinv_param_t param, double lo, double hi);

/**
 * @brief Append a stage to the schedule. Not allowed once a run has started.
 * @param optimizer the optimizer.
 * @param stage the stage; its map must fit the initial medium's grid.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (size, map of another grid,
 *         negative iterations, a schedule that already has
 *         HETINV_MAX_STAGES stages); HETINV_ERROR_INVALID_STATE;
 *         HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_optimizer_add_stage(hetinv_optimizer_t *optimizer,
                                                      const hetinv_stage_t *stage);

/**
 * @brief Append the layer-wise stages of the paper's Fig. 2(b), for
 *        pathlength-resolved frontlit measurements.
 *
 * Layer n holds the voxels whose centre lies between n·h and (n+1)·h from
 * the nearest box face that carries a frontlit row (a row whose sensor is on
 * the face its emitter enters). Stage n frees layer n only (earlier layers
 * stay as estimated, deeper ones as initialised) and keeps the values of
 * frontlit rows whose pathlength window ends before sqrt(d² + (2·(n+1)·h)²),
 * d the distance from the emitter's entry point to the sensor pixel's
 * centre (the shortest path that touches depth (n+1)·h), i.e. light that
 * cannot have gone deeper than layer n. Only identity maps qualify.
 * @param optimizer the optimizer.
 * @param map an identity map of the medium's grid (borrowed).
 * @param layer_thickness h, > 0, in the box's units.
 * @param layers number of layers (stages) to add, ≥ 1; with the stages
 *        already there at most HETINV_MAX_STAGES.
 * @param iterations iterations per stage; 0 = HETINV_OPTIMIZER_ITERATIONS.
 * @return as hetinv_optimizer_add_stage(), plus HETINV_ERROR_INVALID_ARGUMENT
 *         when the set has no pathlength-resolved frontlit row or the map is
 *         not an identity map.
 */
HETINV_API hetinv_result_t hetinv_optimizer_add_layerwise_stages(hetinv_optimizer_t *optimizer,
                                                                 const hetinv_param_map_t *map,
                                                                 double layer_thickness,
                                                                 int32_t layers,
                                                                 int32_t iterations);

/**
 * @brief Set the progress callback (NULL to remove it).
 * @param optimizer the optimizer.
 * @param fn the callback, or NULL.
 * @param user passed to @p fn.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT.
 */
HETINV_API hetinv_result_t hetinv_optimizer_set_progress(hetinv_optimizer_t *optimizer,
                                                         hetinv_progress_fn fn, void *user);

/**
 * @brief Write checkpoints to @p path during runs (NULL to stop).
 * @param optimizer the optimizer.
 * @param path the checkpoint file (copied), replaced atomically each time;
 *        or NULL.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (an empty path); HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_optimizer_set_checkpoint(hetinv_optimizer_t *optimizer,
                                                           const char *path);

/**
 * @brief Write the optimizer's state to a file now (atomically).
 * @param optimizer the optimizer.
 * @param path the file.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_IO;
 *         HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_optimizer_save(const hetinv_optimizer_t *optimizer,
                                                 const char *path);

/**
 * @brief Restore the state of a checkpoint into an optimizer configured as
 *        the one that wrote it (same set, initial medium, tunables, bounds
 *        and stages); the next hetinv_optimizer_run() continues that run.
 *
 * "Same set" means the same values, weights, mask and clip scales, and
 * the same geometry: the box and its indices, and row by row the emitter,
 * sensor and pathlength bins (with any instrument response), compared by
 * a hash of every number that shapes the rendered values, so a set built
 * alike in another process matches. The estimator given to the next run
 * must have the run's tunables (EPOCH aside) and gain mode. Checkpoints of
 * format 6 and older hold no geometry hash or gain mode: they resume
 * without those two checks.
 *
 * The checkpoint is validated field by field against the optimizer's
 * configuration, not only by its checksum (which detects damage, not a
 * stale or crafted file): the stage and iteration counts within the
 * schedule, the file's exact length for them, π and the averaged iterates
 * inside the bounds, the method's accumulators finite (and ≥ 0 where they
 * are means of squares), losses ≥ 0, the estimator's tunables within their
 * bounds, the base medium's values (the initial medium's where no earlier
 * stage frees the parameter, inside its bounds where one does).
 * @param optimizer the optimizer; its run must not have started.
 * @param path the checkpoint: a regular file, no larger than a checkpoint
 *        of this configuration can be.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_IO (cannot open or read, or not a regular file);
 *         HETINV_ERROR_CORRUPT_FILE (bad magic, truncated, checksum, too
 *         large, or a field the configured run cannot have: the message
 *         names the field, its value and the limit);
 *         HETINV_ERROR_UNSUPPORTED (a format version other than 2 to 7,
 *         today's; or another byte order);
 *         HETINV_ERROR_INVALID_ARGUMENT (written by a differently configured
 *         optimizer; the message names what differs, also for a file too
 *         large for this configuration whose header names another one);
 *         HETINV_ERROR_INVALID_STATE (run started); HETINV_ERROR_OUT_OF_MEMORY.
 *         On failure the optimizer is unchanged.
 */
HETINV_API hetinv_result_t hetinv_optimizer_resume(hetinv_optimizer_t *optimizer, const char *path);

/**
 * @brief Run the schedule until it ends, the time budget runs out or the
 *        callback stops it. Calling it again after a stop continues.
 * @param optimizer the optimizer, with at least one stage.
 * @param estimator renders the loss and gradients; its tunables are used,
 *        except EPOCH, which the optimizer sets per iteration (and restores).
 * @param[out] reason why the run ended; may be NULL.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_STATE (no stage);
 *         errors of the estimator and of checkpoint writes.
 *         After a failure (e.g. HETINV_ERROR_OUT_OF_MEMORY) the optimizer
 *         holds the state of its last completed iteration, and calling it
 *         again continues the run as if nothing had failed.
 */
HETINV_API hetinv_result_t hetinv_optimizer_run(hetinv_optimizer_t *optimizer,
                                                hetinv_estimator_t *estimator,
                                                hetinv_stop_reason_t *reason);

/**
 * @brief The current estimate: the average of the trailing iterates of the
 *        current stage, mapped onto a new committed medium.
 * @param optimizer the optimizer.
 * @param[out] out receives the medium (the caller destroys it).
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_optimizer_result(const hetinv_optimizer_t *optimizer,
                                                   hetinv_medium_t **out);

/**
 * @brief The current stage's π: the last iterate or the trailing average.
 * @param optimizer the optimizer.
 * @param averaged non-zero for the trailing average (in the box), 0 for the
 *        last iterate (outside the box by up to HETINV_OPTIMIZER_BOX_MARGIN).
 * @param[out] pi receives the stage's π.
 * @param count length of @p pi; must equal the stage map's size.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_STATE (no stage has started: before the first
 *         hetinv_optimizer_run() or hetinv_optimizer_resume());
 *         HETINV_ERROR_INVALID_ARGUMENT (count).
 */
HETINV_API hetinv_result_t hetinv_optimizer_get_pi(const hetinv_optimizer_t *optimizer,
                                                   int averaged, double *pi, size_t count);

/**
 * @brief Loss of every iteration run so far (the progress callback's values).
 * @param optimizer the optimizer.
 * @param[out] count receives the number of iterations; may be NULL.
 * @return the losses, owned by the optimizer and valid until its next call;
 *         NULL when nothing has run.
 */
HETINV_API const double *hetinv_optimizer_losses(const hetinv_optimizer_t *optimizer,
                                                 size_t *count);

#ifdef __cplusplus
}
#endif

#endif /* HETINV_OPTIMIZER_H */
