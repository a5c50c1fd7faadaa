"""Enum values of the C API, and the names Python callers may use instead."""
from ._args import integer

PARAM_SIGMA_A, PARAM_SIGMA_S, PARAM_G = 0, 1, 2
PARAMS = {"sigma_a": 0, "sigma_s": 1, "g": 2}

FACE_X_MIN, FACE_X_MAX, FACE_Y_MIN, FACE_Y_MAX, FACE_Z_MIN, FACE_Z_MAX = range(6)
FACES = {"x_min": 0, "x_max": 1, "y_min": 2, "y_max": 3, "z_min": 4, "z_max": 5}

WINDOW_BOX, WINDOW_GAUSSIAN = 0, 1
WINDOWS = {"box": 0, "gaussian": 1}

FREE_SIGMA_A, FREE_SIGMA_S, FREE_G = 1, 2, 4
FREE_ALL = 7

ESTIMATOR_PARAMS = {"photons": 0, "batches": 1, "roulette_weight": 2, "roulette_survival": 3,
                    "min_scattering": 4, "max_scattering": 5, "stream": 6, "epoch": 7,
                    "loss_clip": 8}

GAIN_NONE, GAIN_GLOBAL, GAIN_PER_EMITTER = 0, 1, 2
GAIN_MODES = {"none": 0, "global": 1, "per_emitter": 2}
GAIN_MODE_NAMES = {v: k for k, v in GAIN_MODES.items()}

METHOD_ADADELTA, METHOD_SGD, METHOD_ADAGRAD, METHOD_ADAM = range(4)
METHODS = {"adadelta": 0, "sgd": 1, "adagrad": 2, "adam": 3}

OPTIMIZER_PARAMS = {"method": 0, "decay": 1, "epsilon": 2, "learning_rate": 3, "beta1": 4,
                    "beta2": 5, "minibatch": 6, "iterations": 7, "time_budget": 8,
                    "plateau_window": 9, "plateau_tolerance": 10, "average_window": 11,
                    "checkpoint_interval": 12, "coordinates": 13,
                    "smoothness": 14, "multiscale": 15, "box_margin": 16}

COORDINATES_NATIVE, COORDINATES_REDUCED, COORDINATES_LOG, COORDINATES_LOG_REDUCED, COORDINATES_LOG_MEAN_RATIO = range(5)
COORDINATES = {"native": 0, "reduced": 1, "log": 2, "log-reduced": 3, "log-mean-ratio": 4}

STOP_NONE, STOP_COMPLETED, STOP_TIME_BUDGET, STOP_CALLBACK = range(4)
STOP_REASONS = {0: "none", 1: "completed", 2: "time_budget", 3: "callback"}
STOP_REASONS_INV = {v: k for k, v in STOP_REASONS.items()}


def lookup(value, table, what):
    """An enum value from an int or one of `table`'s names. Unknown ints
    that fit an int32 are passed through, so the library reports them in its
    own words; others are an OverflowError (ctypes would wrap them)."""
    if isinstance(value, str):
        try:
            return table[value.lower()]
        except KeyError:
            raise ValueError("unknown %s %r; expected one of %s"
                             % (what, value, ", ".join(sorted(table)))) from None
    return integer(value, what, "int32")


def free_mask(free):
    """A HETINV_FREE() mask from an int (a FREE_* mask), a parameter name, or
    an iterable of names. An int inside an iterable is refused: a FREE_*
    mask and a PARAM_* id are both ints (FREE_SIGMA_A == PARAM_SIGMA_S), so
    it could mean either parameter."""
    if not isinstance(free, str) and not hasattr(free, "__iter__"):
        return integer(free, "free", "uint32")
    if isinstance(free, str):
        free = [free]
    mask = 0
    for p in free:
        if not isinstance(p, str):
            raise TypeError("free: %r inside a list; give parameter names there (\"sigma_a\", \"sigma_s\", "
                            "\"g\"), or one FREE_* mask alone (FREE_SIGMA_A | FREE_SIGMA_S): an int in a list "
                            "could be a mask or a parameter id" % (p,))
        mask |= 1 << lookup(p, PARAMS, "parameter")
    return mask
