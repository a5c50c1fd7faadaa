"""The Monte Carlo estimator: render, gradient, loss gradient, statistics (estimator.h)."""
import ctypes
from collections import namedtuple

from . import _arrays
from ._args import integer, number
from ._errors import check
from ._handle import Handle, handle_arg, pinned
from ._lib import lib
from ._names import ESTIMATOR_PARAMS, lookup
from ._structs import RenderStats


class Render(namedtuple("Render", "values std_errors ballistic")):
    """What Estimator.render returns. values, std_errors and ballistic are
    flat, one item per value of the measurement set (rows one after the
    other, as the set lays them out); row(r) is one row's values shaped
    (bins, height, width) with numpy, the way the sensor sees them."""

    _rows = ()  # [(offset, shape)] of each row, set by Estimator.render

    def row(self, row, which="values"):
        """Row `row` of `which` ("values", "std_errors" or "ballistic"): with
        numpy a view of shape (bins, height, width), else a flat slice."""
        if which not in self._fields:
            raise ValueError("which: expected one of %s, got %r" % (self._fields, which))
        row = integer(row, "row")
        if not 0 <= row < len(self._rows):
            raise IndexError("row %d: the rendered set has %d rows" % (row, len(self._rows)))
        offset, shape = self._rows[row]
        count = shape[0] * shape[1] * shape[2]
        return _arrays.shaped(getattr(self, which)[offset:offset + count], shape)


Gradient = namedtuple("Gradient", "grad std_errors")
Gradient.__doc__ = """grad and std_errors: one item per π entry, shaped param_map.shape
(free parameters, cz, cy, cx) with numpy."""
LossGradient = namedtuple("LossGradient", "loss grad rendered")
LossGradient.__doc__ = """loss, grad (shaped param_map.shape with numpy) and the rendered
values (flat, like Render.values)."""


def estimator_param_bounds(param):
    """(lo, hi) of an estimator tunable ("photons", ... or its id)."""
    lo, hi = ctypes.c_double(), ctypes.c_double()
    check(lib.estimator_param_bounds(lookup(param, ESTIMATOR_PARAMS, "estimator parameter"),
                                     ctypes.byref(lo), ctypes.byref(hi)))
    return lo.value, hi.value


class Estimator(Handle):
    """hetinv_estimator_t. Tunables as keywords or via set_param/get_param:
    photons, batches, roulette_weight, roulette_survival, min_scattering,
    max_scattering, stream, epoch.

        est = hetinv.Estimator(ctx, photons=20000)
        r = est.render(medium, measurements)   # r.values, r.std_errors, r.ballistic
        r.row(0)                               # row 0, shaped (bins, height, width)
    """

    _destroy_name = "estimator_destroy"
    param_bounds = staticmethod(estimator_param_bounds)

    def __init__(self, ctx, **params):
        from .context import Context

        c = handle_arg(ctx, Context, "ctx")
        h = ctypes.c_void_p()
        check(lib.estimator_create(c, ctypes.byref(h)))
        super().__init__(h, [ctx])
        self.context = ctx
        for name, value in params.items():
            self.set_param(name, value)

    def set_param(self, param, value):
        check(lib.estimator_set_param(self._ptr, lookup(param, ESTIMATOR_PARAMS,
                                                        "estimator parameter"),
                                      number(value, "value")))
        return self

    def get_param(self, param):
        v = ctypes.c_double()
        check(lib.estimator_get_param(self._ptr, lookup(param, ESTIMATOR_PARAMS,
                                                        "estimator parameter"), ctypes.byref(v)))
        return v.value

    def render(self, medium, measurements):
        """Render every value of the set: Render(values, std_errors, ballistic)."""
        mp, sp = _inputs(medium, measurements)
        n = measurements.value_count
        values, pv = _arrays.empty(n)
        errors, pe = _arrays.empty(n)
        ballistic, pb = _arrays.empty(n)
        rows = measurements._row_layouts()
        with pinned(self, medium, measurements):
            check(lib.estimator_render(self._ptr, mp, sp, pv, pe, pb, n))
        r = Render(values, errors, ballistic)
        r._rows = rows
        return r

    def gradient(self, medium, measurements, cotangent, param_map):
        """Σ_n cotangent[n]·∂I_n/∂π: Gradient(grad, std_errors), each shaped
        param_map.shape with numpy. cotangent: value_count values, any shape."""
        mp, sp = _inputs(medium, measurements)
        pm = _map(param_map)
        c = _arrays.to_c(cotangent, "d", measurements.value_count, "cotangent")
        k = param_map.size
        grad, pg = _arrays.empty(k, "d", param_map.shape)
        errors, pe = _arrays.empty(k, "d", param_map.shape)
        with pinned(self, medium, measurements, param_map):
            check(lib.estimator_gradient(self._ptr, mp, sp, c.ptr, c.count, pm, pg, pe, k))
        return Gradient(grad, errors)

    def loss_gradient(self, medium, measurements, param_map):
        """The loss of Eq. (9) against the set's measured values, its
        gradient with respect to π, and the rendered values."""
        mp, sp = _inputs(medium, measurements)
        pm = _map(param_map)
        k, n = param_map.size, measurements.value_count
        loss = ctypes.c_double()
        rendered, pr = _arrays.empty(n)  # value_count values: the C function is not told n
        grad, pg = _arrays.empty(k, "d", param_map.shape)
        with pinned(self, medium, measurements, param_map):
            check(lib.estimator_loss_gradient(self._ptr, mp, sp, pm, ctypes.byref(loss), pr, pg, k))
        return LossGradient(loss.value, grad, rendered)

    def stats(self):
        """RenderStats of the last render (photons, seconds, specular,
        absorbed, escaped[6], ...)."""
        s = RenderStats()
        check(lib.estimator_get_stats(self._ptr, ctypes.byref(s)))
        return s


def _inputs(medium, measurements):
    from .measurements import Measurements
    from .medium import Medium

    return handle_arg(medium, Medium, "medium"), handle_arg(measurements, Measurements,
                                                            "measurements")


def _map(param_map):
    from .param import ParamMap

    return handle_arg(param_map, ParamMap, "param_map")
