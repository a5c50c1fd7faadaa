"""Simulated acquisition: the sensor noise model (acquire.h). The volume
generators are Medium.fill_gaussian_mixture and Medium.fill_smoke."""
import ctypes
from collections import namedtuple

from . import _arrays
from ._errors import check
from ._handle import handle_arg
from ._lib import lib
from ._structs import NoiseModel

Noisy = namedtuple("Noisy", "values std_errors exposure")


def apply_noise(ctx, clean, model=None, **fields):
    """What a camera records for `clean` values under the Hasinoff affine
    noise model: Noisy(values, std_errors, exposure). model: a NoiseModel,
    or its fields as keywords over the library defaults (e.g. seed=3,
    read_noise=2.0). With numpy, values and std_errors have the shape of a
    numpy `clean` (flat for any other input)."""
    from .context import Context
    from .medium import _spec

    cp = handle_arg(ctx, Context, "ctx")
    model = _spec(model, fields, NoiseModel, "model")
    c = _arrays.to_c(clean, "d", name="clean")
    shape = clean.shape if _arrays.is_numpy(clean) else None
    noisy, pn = _arrays.empty(c.count, "d", shape)
    errors, pe = _arrays.empty(c.count, "d", shape)
    exposure = ctypes.c_double()
    check(lib.noise_apply(cp, ctypes.byref(model), c.ptr, pn, pe, c.count,
                          ctypes.byref(exposure)))
    return Noisy(noisy, errors, exposure.value)
