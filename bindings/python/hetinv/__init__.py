"""Python binding of libhetinv (pure ctypes): heterogeneous inverse
scattering with a differentiable Monte Carlo renderer.

The library is found through the HETINV_LIBRARY environment variable (a
path), else ctypes.util.find_library("hetinv"), else pkg-config's libdir
of hetinv, else the usual prefixes, else "libhetinv.so.0" through the
dynamic loader (see _lib.py; the ImportError lists where it looked).
Arrays come back as numpy arrays when numpy is importable, shaped like
their grid (medium grids (nz, ny, nx), π and gradients ParamMap.shape),
else as flat array.array; any sequence of numbers is accepted as input.
"""
from ._lib import lib as _clib, path as library_path
from ._errors import (
    CorruptFileError,
    FileIOError,
    HetinvError,
    InternalError,
    InvalidArgumentError,
    InvalidStateError,
    NullArgumentError,
    OutOfMemoryError,
    OutOfRangeError,
    SizeOverflowError,
    UnsupportedError,
    error_for,
)
from ._arrays import flat, numpy_available, numpy_enabled, use_numpy
from ._names import (
    COORDINATES_NATIVE, COORDINATES_REDUCED, COORDINATES_LOG, COORDINATES_LOG_REDUCED, COORDINATES_LOG_MEAN_RATIO,
    FACE_X_MAX, FACE_X_MIN, FACE_Y_MAX, FACE_Y_MIN, FACE_Z_MAX, FACE_Z_MIN,
    FREE_ALL, FREE_G, FREE_SIGMA_A, FREE_SIGMA_S,
    GAIN_GLOBAL, GAIN_NONE, GAIN_PER_EMITTER,
    METHOD_ADADELTA, METHOD_ADAGRAD, METHOD_ADAM, METHOD_SGD,
    PARAM_G, PARAM_SIGMA_A, PARAM_SIGMA_S,
    WINDOW_BOX, WINDOW_GAUSSIAN,
)
from ._structs import MixtureSpec, NoiseModel, RenderStats, SmokeSpec, VolHeader
from .context import Context
from .medium import Medium, param_name, vol_read, vol_read_header, vol_write
from .sampling import Emitter, Pathlength, Sensor, irf_offsets_from_times
from .measurements import Measurements
from .param import ParamMap
from .estimator import Bound, Estimator, Fisher, Gradient, LossGradient, Render, estimator_param_bounds
from .optimizer import Optimizer, Progress, optimizer_param_bounds
from .acquire import Noisy, apply_noise
from .image import COLORMAP_GRAY, COLORMAP_VIRIDIS, Image, read_exr

__version__ = "0.3.0"  # the library version this package is written for (pyproject.toml reads it)


def version():
    """Version of the loaded library, "MAJOR.MINOR.PATCH"."""
    return _clib.version_string().decode()


def version_number():
    """Version of the loaded library as MAJOR·10000 + MINOR·100 + PATCH."""
    return _clib.version_number()


def build_has_mpi():
    """True if the loaded library was built with MPI (HETINV_WITH_MPI)."""
    return bool(_clib.build_has_mpi())


def result_name(code):
    """Static name of a result code, e.g. "HETINV_ERROR_INVALID_ARGUMENT"."""
    from ._args import integer

    return _clib.result_name(integer(code, "code")).decode()
