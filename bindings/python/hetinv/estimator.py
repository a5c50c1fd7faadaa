"""The Monte Carlo estimator: render, gradient, loss gradient, statistics (estimator.h)."""
import ctypes
from collections import namedtuple

from . import _arrays
from ._args import integer, number
from ._errors import check
from ._handle import Handle, handle_arg, one_thread, pinned
from ._lib import lib
from ._names import ESTIMATOR_PARAMS, GAIN_MODE_NAMES, GAIN_MODES, lookup
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
Fisher = namedtuple("Fisher", "fisher std_errors")
Fisher.__doc__ = """The Fisher information of the map's K entries and its standard
errors (K × K with numpy; flat, row-major, without)."""
Bound = namedtuple("Bound", "sd std_errors lower positive_definite")
Bound.__doc__ = """Cramér–Rao standard deviations sqrt((F⁻¹)_kk), their jackknife
standard errors and the lower bound sqrt(1/F_kk), each shaped
param_map.shape with numpy; positive_definite False means sd is NaN
(the estimated F is not positive definite; lower is still valid)."""
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
    max_scattering, stream, epoch, loss_clip (Huber's loss of loss_gradient).

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

    @one_thread
    def set_param(self, param, value):
        check(lib.estimator_set_param(self._ptr, lookup(param, ESTIMATOR_PARAMS,
                                                        "estimator parameter"),
                                      number(value, "value")))
        return self

    @one_thread
    def get_param(self, param):
        v = ctypes.c_double()
        check(lib.estimator_get_param(self._ptr, lookup(param, ESTIMATOR_PARAMS,
                                                        "estimator parameter"), ctypes.byref(v)))
        return v.value

    @one_thread
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

    @one_thread
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

    @one_thread
    def jvp(self, medium, measurements, param_map, tangent):
        """J·v: for every value n, Σ_k ∂I_n/∂π_k·tangent[k]. Returns
        Gradient-like (values, std_errors), flat like Render.values."""
        mp, sp = _inputs(medium, measurements)
        pm = _map(param_map)
        v = _arrays.to_c(tangent, "d", param_map.size, "tangent")
        n = measurements.value_count
        jv, pj = _arrays.empty(n)
        errors, pe = _arrays.empty(n)
        with pinned(self, medium, measurements, param_map):
            check(lib.estimator_jvp(self._ptr, mp, sp, pm, v.ptr, v.count, pj, pe, n))
        return Gradient(jv, errors)

    @one_thread
    def fisher(self, medium, measurements, variances, param_map, replicates=8):
        """F = JᵀΣ⁻¹J of the map's entries (unbiased: two independent
        Jacobian estimates per replicate), with standard errors (bound.h)."""
        mp, sp = _inputs(medium, measurements)
        pm = _map(param_map)
        var = _arrays.to_c(variances, "d", measurements.value_count, "variances")
        k = param_map.size
        f, pf = _arrays.empty(k * k, "d", (k, k))
        errors, pe = _arrays.empty(k * k, "d", (k, k))
        with pinned(self, medium, measurements, param_map):
            check(lib.estimator_fisher(self._ptr, mp, sp, var.ptr, var.count, pm,
                                       integer(replicates, "replicates", "int32"), pf, pe, k))
        return Fisher(f, errors)

    @one_thread
    def crb(self, medium, measurements, variances, param_map, replicates=8):
        """The Cramér–Rao bound of every map entry (bound.h): Bound(sd,
        std_errors, lower, positive_definite)."""
        mp, sp = _inputs(medium, measurements)
        pm = _map(param_map)
        var = _arrays.to_c(variances, "d", measurements.value_count, "variances")
        k = param_map.size
        sd, ps = _arrays.empty(k, "d", param_map.shape)
        errors, pe = _arrays.empty(k, "d", param_map.shape)
        lower, pl = _arrays.empty(k, "d", param_map.shape)
        pd = ctypes.c_int32()
        with pinned(self, medium, measurements, param_map):
            check(lib.estimator_crb(self._ptr, mp, sp, var.ptr, var.count, pm,
                                    integer(replicates, "replicates", "int32"), ps, pe, pl, k,
                                    ctypes.byref(pd)))
        return Bound(sd, errors, lower, bool(pd.value))

    @one_thread
    def fisher_diagonal(self, medium, measurements, variances, param_map, probes=16):
        """The diagonal of F by Hutchinson probes, for maps too large for the
        dense matrix; 1/sqrt of it is a lower bound of the CRB. Returns
        Gradient-like (diagonal, std_errors) shaped param_map.shape."""
        mp, sp = _inputs(medium, measurements)
        pm = _map(param_map)
        var = _arrays.to_c(variances, "d", measurements.value_count, "variances")
        k = param_map.size
        d, pd = _arrays.empty(k, "d", param_map.shape)
        errors, pe = _arrays.empty(k, "d", param_map.shape)
        with pinned(self, medium, measurements, param_map):
            check(lib.estimator_fisher_diagonal(self._ptr, mp, sp, var.ptr, var.count, pm,
                                                integer(probes, "probes", "int32"), pd, pe, k))
        return Gradient(d, errors)

    @one_thread
    def fisher_blocks(self, medium, measurements, variances, param_map, spacing=2, replicates=4):
        """Each cell's block of F (its own free parameters), matrix-free for
        maps of any size: probes on classes of cells `spacing` apart
        (bound.h). Returns Gradient-like (blocks, std_errors), each shaped
        (cz, cy, cx, P, P) with numpy (P = len(param_map.params); the
        library's order, cell c's block at [(c·P + a)·P + b], flat
        without); turn them into the local bound at radius 0 with
        ParamMap.blocks_crb()."""
        mp, sp = _inputs(medium, measurements)
        pm = _map(param_map)
        var = _arrays.to_c(variances, "d", measurements.value_count, "variances")
        k, P = param_map.size, len(param_map.params)
        shape = param_map.shape[1:] + (P, P)
        b, pb = _arrays.empty(k * P, "d", shape)
        errors, pe = _arrays.empty(k * P, "d", shape)
        with pinned(self, medium, measurements, param_map):
            check(lib.estimator_fisher_blocks(self._ptr, mp, sp, var.ptr, var.count, pm,
                                              integer(spacing, "spacing", "int32"),
                                              integer(replicates, "replicates", "int32"), pb, pe, k))
        return Gradient(b, errors)

    @one_thread
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

    @property
    @one_thread
    def gain_mode(self):
        """Calibration gain of loss_gradient: "none" (default), "global" or
        "per_emitter" (settable by name or id). The model is scaled by the
        least-squares gain at every call; read the gains with gains()."""
        m = ctypes.c_int32()
        check(lib.estimator_get_gain_mode(self._ptr, ctypes.byref(m)))
        return GAIN_MODE_NAMES.get(m.value, m.value)

    @gain_mode.setter
    @one_thread
    def gain_mode(self, mode):
        check(lib.estimator_set_gain_mode(self._ptr, lookup(mode, GAIN_MODES, "gain mode")))

    @one_thread
    def gains(self):
        """The gains fitted by the last loss_gradient: one (global) or one
        per emitter of its set, in order of first use (flat array)."""
        n = ctypes.c_size_t()
        check(lib.estimator_get_gains(self._ptr, None, 0, ctypes.byref(n)))
        out, po = _arrays.empty(n.value)
        check(lib.estimator_get_gains(self._ptr, po, n.value, ctypes.byref(n)))
        return out

    @one_thread
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
