/* hetinv-fig4's command line (fig4_options.h). */
#include "fig4_options.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "hetinv/bound.h"
#include "polish.h"

/* --help prints to stdout (for a pager), a usage error to stderr. */
static void print_usage(FILE *to, const char *what) {
  fprintf(to,
          "hetinv-fig4: %s\n"
          "usage: hetinv-fig4 [--full] [--volumes N|A-B] [--configs 1,2,3,4] [--iterations N]\n"
          "                   [--photons N] [--minibatch N] [--epsilon E] [--epsilon-start E] [--decay D]\n"
          "                   [--coarse-epsilon-start E] [--settle-epsilon E] [--settle-fraction F]\n"
          "                   [--settle-photons P]\n"
          "                   [--coarse-fraction F] [--coarse-levels none|A,B,...] [--stage-results]\n"
          "                   [--coarse-window N] [--loss-clip C] [--loss-clip-errors data|residual|residual_above]\n"
          "                   [--independent-errors] [--pooled-errors]\n"
          "                   [--expected-camera-errors] [--residual-weights]\n"
          "                   [--smoothness L] [--multiscale A] [--box-margin M] [--truth-photons N] [--seed N]\n"
          "                   [--coordinates native|reduced|log|log-reduced|log-mean-ratio] [--grid N] [--scale S]\n"
          "                   [--method adadelta|sgd|adagrad|adam] [--rate R] [--beta1 B] [--beta2 B]\n"
          "                   [--min-snr S] [--min-snr-errors data|residual] [--threads N] [-o DIR] [--quiet]\n"
          "                   [--write-scenes] [--bound | --bound-only] [--bound-photons N]\n"
          "                   [--bound-replicates N] [--bound-from DIR] [--init-truth] [--init-geometric] [--fit-check] [--fit-photons N]\n"
          "                   [--fit-replicates N] [--gradient-check N] [--polish N] [--polish-steps S]\n"
          "                   [--polish-fisher R] [--polish-fisher-photons N]\n"
          "                   [--polish-damping D] [--polish-max-step S] [--polish-cg N]\n",
          what);
}

static int usage(const char *what) {
  print_usage(stderr, what);
  return 2;
}

/* --coarse-levels: "none", or cells per axis of each coarser stage,
 * increasing, comma-separated (at most RECON_MAX_LEVELS - 1 of them). */
static int parse_levels(const char *opt, const char *text, fig4_options_t *o) {
  if (text == NULL) {
    fprintf(stderr, "hetinv-fig4: %s needs a value\n", opt);
    return -1;
  }
  o->coarse_level_count = 0;
  if (strcmp(text, "none") == 0) return 0;
  const char *p = text;
  for (;;) {
    char *end = NULL;
    long v = strtol(p, &end, 10);
    int n = o->coarse_level_count;
    if (end == p || v < 1 || v > 4096 || (n > 0 && v <= o->coarse_levels[n - 1]) || n == RECON_MAX_LEVELS - 1 ||
        (*end != ',' && *end != '\0')) {
      fprintf(stderr,
              "hetinv-fig4: %s: '%s' is not \"none\" or at most %d increasing cell counts from 1 to 4096, "
              "comma-separated\n", opt, text, RECON_MAX_LEVELS - 1);
      return -1;
    }
    o->coarse_levels[o->coarse_level_count++] = (int32_t)v;
    if (*end == '\0') return 0;
    p = end + 1;
  }
}

int fig4_options_parse(int argc, char **argv, fig4_options_t *o) {
  *o = (fig4_options_t){
      .configs = {false, true, true, true, true},
      .out = "out/fig4",
      .volumes = -1, .iterations = -1, .photons = -1, .minibatch = -1, .grid = -1, .threads = -1,
      .truth_photons = -1, .coarse_window = -1,
      .bound_photons = -1, .bound_replicates = 4, .fit_photons = 20000, .fit_replicates = 4, .gradient_replicates = 0,
      .polish_replicates = 0, .polish_steps = 2, .polish_fisher = 2, .polish_damping = 0.01,
      .polish_fisher_photons = 0, .polish_cg = 0, .polish_max_step = 0.05,
      .scale = -1.0, .epsilon = -1.0, .min_snr = -1.0, .decay = -1.0, .coarse_fraction = -1.0, .coarse_level_count = -1, .epsilon_start = -1.0, .coarse_epsilon_start = -1.0, .settle_epsilon = -1.0, .settle_fraction = -1.0, .settle_photons = -1.0,
      .loss_clip = -1.0, .loss_clip_errors = -1, .min_snr_errors = -1, .smoothness = -1.0, .multiscale = -1.0, .box_margin = -1.0,
      .coordinates = -1, .method = -1, .rate = -1.0, .beta1 = -1.0, .beta2 = -1.0,
  };
  for (int i = 1; i < argc; ++i) {
    const char *a = argv[i];
    const char *next = i + 1 < argc ? argv[i + 1] : NULL;
    if (strcmp(a, "--full") == 0) {
      o->full = true;
    } else if (strcmp(a, "--quiet") == 0) {
      o->quiet = true;
    } else if (strcmp(a, "--write-scenes") == 0) {
      o->write_scenes = true;
    } else if (strcmp(a, "--init-truth") == 0) {
      o->init_truth = true;
    } else if (strcmp(a, "--init-geometric") == 0) {
      o->init_geometric = true;
    } else if (strcmp(a, "--fit-check") == 0) {
      o->fit = true;
    } else if (strcmp(a, "--fit-photons") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 1, INT64_C(1) << 40, &o->fit_photons) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--fit-replicates") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 2, 1000, &o->fit_replicates) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--gradient-check") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 2, 1000, &o->gradient_replicates) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--polish") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 2, 1000, &o->polish_replicates) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--polish-steps") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 1, 100, &o->polish_steps) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--polish-fisher") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 2, POLISH_MAX_FISHER_REPLICATES, &o->polish_fisher) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--polish-fisher-photons") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 1, INT64_C(1) << 40, &o->polish_fisher_photons) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--polish-cg") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 1, 100000, &o->polish_cg) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--polish-max-step") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 1e-9, 1e3, &o->polish_max_step) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--polish-damping") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 1e-9, 1e3, &o->polish_damping) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--bound") == 0) {
      o->bound = true;
    } else if (strcmp(a, "--bound-from") == 0) {
      if (next == NULL) return usage("--bound-from needs the output folder of another run");
      if (recon_parse_folder("hetinv-fig4", a, next, FIG4_CELL_FOLDER_MAX) < 0) return 2;
      o->bound_from = next;
      ++i;
    } else if (strcmp(a, "--bound-only") == 0) {
      o->bound_only = true;
    } else if (strcmp(a, "--bound-photons") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 1, INT64_C(1) << 40, &o->bound_photons) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--bound-replicates") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 2, HETINV_FISHER_MAX_REPLICATES, &o->bound_replicates) < 0) return 2;
      ++i;
    } else if (strcmp(a, "-o") == 0) {
      if (next == NULL) return usage("-o needs a directory");
      if (recon_parse_folder("hetinv-fig4", a, next, FIG4_CELL_FOLDER_MAX) < 0) return 2;
      o->out = argv[++i];
    } else if (strcmp(a, "--volumes") == 0) {
      /* N (volumes 1..N) or A-B: separate ranges run side by side in
       * separate folders, whose cells a later run reads back together. */
      const char *dash = next ? strchr(next, '-') : NULL;
      if (dash != NULL && dash != next) {
        char *end = NULL;
        long a0 = strtol(next, &end, 10), b0 = end == dash ? strtol(dash + 1, &end, 10) : -1;
        if (*end != '\0' || a0 < 1 || b0 < a0 || b0 > 100) {
          char msg[300];
          snprintf(msg, sizeof msg, "--volumes: '%s' is neither a count nor a range A-B within 1-100", next);
          return usage(msg);
        }
        o->first_volume = a0 - 1;
        o->volumes = b0 - a0 + 1;
      } else if (recon_parse_count("hetinv-fig4", a, next, 1, 100, &o->volumes) < 0) {
        return 2;
      }
      ++i;
    } else if (strcmp(a, "--iterations") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 1, 1000000000, &o->iterations) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--photons") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 1, 1000000000, &o->photons) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--truth-photons") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 1, 1000000000, &o->truth_photons) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--seed") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 1, (int64_t)1 << 53, &o->seed) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--minibatch") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 1, 100000, &o->minibatch) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--grid") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 2, 256, &o->grid) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--scale") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 1e-3, 1e3, &o->scale) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--epsilon") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 1e-9, 1.0, &o->epsilon) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--epsilon-start") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 1e-9, 1.0, &o->epsilon_start) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--settle-epsilon") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 0.0, 1.0, &o->settle_epsilon) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--settle-photons") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 1.0, 1e6, &o->settle_photons) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--settle-fraction") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 0.0, 0.999999, &o->settle_fraction) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--coarse-epsilon-start") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 1e-9, 1.0, &o->coarse_epsilon_start) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--coarse-window") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 0, 4096, &o->coarse_window) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--independent-errors") == 0) {
      o->independent_errors = true;
    } else if (strcmp(a, "--pooled-errors") == 0) {
      o->pooled_errors = true;
    } else if (strcmp(a, "--expected-camera-errors") == 0) {
      o->expected_camera_errors = true;
    } else if (strcmp(a, "--residual-weights") == 0) {
      o->residual_weights = true;
    } else if (strcmp(a, "--min-snr-errors") == 0) {
      if (recon_parse_choice("hetinv-fig4", a, next, recon_snr_errors_names, &o->min_snr_errors) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--loss-clip-errors") == 0) {
      if (recon_parse_choice("hetinv-fig4", a, next, recon_clip_errors_names, &o->loss_clip_errors) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--loss-clip") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 0.0, 1e6, &o->loss_clip) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--smoothness") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 0.0, 1e12, &o->smoothness) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--multiscale") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 0.0, 100.0, &o->multiscale) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--box-margin") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 0.0, 1.0, &o->box_margin) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--coarse-levels") == 0) {
      if (parse_levels(a, next, o) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--stage-results") == 0) {
      o->stage_results = true;
    } else if (strcmp(a, "--coarse-fraction") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 1e-6, 1.0, &o->coarse_fraction) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--decay") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 0.0, 0.999999, &o->decay) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--method") == 0) {
      if (recon_parse_choice("hetinv-fig4", a, next, recon_method_names, &o->method) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--rate") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 1e-9, 1.0, &o->rate) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--beta1") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 0.0, 0.999999, &o->beta1) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--beta2") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 0.0, 0.999999, &o->beta2) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--coordinates") == 0) {
      if (recon_parse_choice("hetinv-fig4", a, next, recon_coordinate_names, &o->coordinates) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--min-snr") == 0) {
      if (recon_parse_real("hetinv-fig4", a, next, 0.0, 1e6, &o->min_snr) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--threads") == 0) {
      if (recon_parse_count("hetinv-fig4", a, next, 0, HETINV_MAX_THREADS, &o->threads) < 0) return 2;
      ++i;
    } else if (strcmp(a, "--configs") == 0) {
      if (next == NULL) return usage("--configs needs a list such as 1,2,4");
      for (int c = 1; c <= 4; ++c) o->configs[c] = false;
      for (const char *p = argv[++i]; *p; ++p) {
        if (*p >= '1' && *p <= '4') {
          o->configs[*p - '0'] = true;
        } else if (*p != ',') {
          char msg[200];
          snprintf(msg, sizeof msg, "--configs: '%s' is not a list of 1, 2, 3 and 4", argv[i]);
          return usage(msg);
        }
      }
      if (!o->configs[1] && !o->configs[2] && !o->configs[3] && !o->configs[4]) {
        char msg[200];
        snprintf(msg, sizeof msg, "--configs: '%s' names no configuration", argv[i]);
        return usage(msg);
      }
    } else if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
      print_usage(stdout, "the paper's Fig. 4: imaging configurations compared on random volumes");
      return 1;
    } else {
      char msg[300];
      snprintf(msg, sizeof msg, "unknown option '%s'", a);
      return usage(msg);
    }
  }
  if (o->bound && o->bound_only) return usage("--bound and --bound-only exclude each other");
  if (o->bound_from != NULL) {
    /* A mistyped folder would silently cost the whole bound's computation. */
    struct stat st;
    int r = stat(o->bound_from, &st);
    if (r != 0 || !S_ISDIR(st.st_mode)) {
      char msg[1400];
      snprintf(msg, sizeof msg, "--bound-from: '%s' is not a folder (%s)", o->bound_from,
               r != 0 ? strerror(errno) : "a file");
      return usage(msg);
    }
  }
  if (o->write_scenes && (o->bound || o->bound_only)) return usage("--write-scenes writes set-ups; it computes no bound");
  if (o->fit && (o->write_scenes || o->bound_only)) return usage("--fit-check needs the cells' recoveries");
  if (o->gradient_replicates > 0 && (o->write_scenes || o->bound_only)) {
    return usage("--gradient-check needs the cells' recoveries");
  }
  if (o->polish_replicates > 0 && (o->write_scenes || o->bound_only)) {
    return usage("--polish needs the cells' recoveries");
  }
  if (o->polish_replicates * o->polish_steps > POLISH_MAX_GRADIENTS) {
    char msg[200];
    snprintf(msg, sizeof msg, "--polish %lld with --polish-steps %lld renders %lld gradients; at most %d",
             (long long)o->polish_replicates, (long long)o->polish_steps,
             (long long)(o->polish_replicates * o->polish_steps), POLISH_MAX_GRADIENTS);
    return usage(msg);
  }
  if ((o->settle_epsilon >= 0.0) != (o->settle_fraction >= 0.0)) {
    return usage("--settle-epsilon and --settle-fraction go together");
  }
  if ((o->settle_epsilon == 0.0) != (o->settle_fraction == 0.0)) {
    char msg[200];
    snprintf(msg, sizeof msg,
             "--settle-epsilon 0 (no settling part) goes with --settle-fraction 0, and only with it; given %g and %g",
             o->settle_epsilon, o->settle_fraction);
    return usage(msg);
  }
  if (o->volumes < 0) o->volumes = o->full ? 5 : 2;
  if (o->scale < 0.0) o->scale = o->full ? 0.1 : 1.0;
  return 0;
}

void fig4_options_apply(const fig4_options_t *o, recon_scene_t *sc) {
  if (o->coordinates >= 0) sc->coordinates = o->coordinates;
  if (o->method >= 0) sc->method = o->method;
  if (o->rate > 0.0) sc->learning_rate = o->rate;
  if (o->beta1 >= 0.0) sc->beta1 = o->beta1;
  if (o->beta2 >= 0.0) sc->beta2 = o->beta2;
  if (o->decay >= 0.0) sc->decay = o->decay;
  if (o->coarse_fraction > 0.0) sc->coarse_fraction = o->coarse_fraction;
  if (o->coarse_level_count >= 0 && !sc->init_at_truth) { /* from the truth: the finest level alone already */
    int32_t finest = sc->levels[sc->level_count - 1], n = 0;
    for (int32_t l = 0; l < o->coarse_level_count; ++l) {
      if (o->coarse_levels[l] < finest) sc->levels[n++] = o->coarse_levels[l];
    }
    sc->levels[n++] = finest;
    sc->level_count = n;
    sc->levels_keyed = true;
  }
  if (o->stage_results) sc->stage_results = true;
  if (o->epsilon_start > 0.0) sc->epsilon_start = o->epsilon_start;
  if (o->coarse_epsilon_start > 0.0) sc->coarse_epsilon_start = o->coarse_epsilon_start;
  if (o->settle_epsilon >= 0.0) { /* 0 (with fraction 0): none, (2) and (4)'s --full default off */
    sc->settle_epsilon = o->settle_epsilon;
    sc->settle_fraction = o->settle_fraction;
  }
  if (o->settle_photons > 0.0) { /* the cell's settling part, or its finest stage's second half if it has none */
    sc->settle_photons = o->settle_photons;
    if (sc->settle_fraction == 0.0) sc->settle_fraction = 0.5;
  }
  if (o->coarse_window >= 0) sc->coarse_average_window = (int32_t)o->coarse_window;
  if (o->loss_clip >= 0.0) sc->loss_clip = o->loss_clip;
  if (o->loss_clip_errors >= 0) sc->loss_clip_errors = o->loss_clip_errors;
  if (o->min_snr_errors >= 0) sc->min_snr_errors = o->min_snr_errors;
  if (o->smoothness >= 0.0) sc->smoothness = o->smoothness;
  if (o->multiscale >= 0.0) sc->multiscale = o->multiscale;
  if (o->box_margin >= 0.0) sc->box_margin = o->box_margin;
  if (o->truth_photons > 0) sc->truth_photons = o->truth_photons;
  if (o->seed > 0) sc->seed = (uint64_t)o->seed;
  if (o->independent_errors) sc->independent_errors = true;
  if (o->pooled_errors) sc->pooled_errors = true;
  if (o->expected_camera_errors) sc->expected_camera_errors = true;
  if (o->residual_weights) sc->weighting = RECON_WEIGHT_RESIDUAL;
}
