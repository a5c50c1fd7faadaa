"""Appearance matching by stochastic gradient descent (optimizer.h)."""
import ctypes
from collections import namedtuple

from . import _arrays
from ._args import integer, number, path as _path
from ._errors import HetinvError, check
from ._handle import Handle, exclusive, handle_arg, one_thread, pinned
from ._lib import PROGRESS_FN, lib
from ._names import COORDINATES, METHODS, OPTIMIZER_PARAMS, STOP_REASONS, STOP_REASONS_INV, lookup  # noqa: F401
from .context import Context
from .estimator import Estimator
from .measurements import Measurements
from .medium import Medium, param_id
from .param import ParamMap

#: What the progress callable receives after every iteration (a copy of
#: hetinv_progress_t).
Progress = namedtuple("Progress", "stage stage_count iteration stage_iteration stage_iterations "
                                  "total_iterations loss step elapsed")


def optimizer_param_bounds(param):
    """(lo, hi) of an optimizer tunable ("method", "decay", ... or its id)."""
    lo, hi = ctypes.c_double(), ctypes.c_double()
    check(lib.optimizer_param_bounds(lookup(param, OPTIMIZER_PARAMS, "optimizer parameter"),
                                     ctypes.byref(lo), ctypes.byref(hi)))
    return lo.value, hi.value


def _mask_bytes(mask, count, name):
    """`count` flags as bytes: the library reads exactly that many, unasked."""
    return _arrays.flags(mask, count, name)


class Optimizer(Handle):
    """hetinv_optimizer_t for one measurement set and initial medium.

        opt = hetinv.Optimizer(ctx, measurements, initial, method="adadelta")
        opt.set_bounds("sigma_s", 1.0, 10.0)
        opt.add_stage(coarse_map, iterations=20)
        opt.add_stage(fine_map, iterations=20)
        opt.set_progress(lambda p: print(p.iteration, p.loss))
        opt.run(estimator)
        result = opt.result()

    The C optimizer borrows the set and the stage maps: this object keeps
    them (and the initial medium) alive, and closing one of them closes the
    optimizer first. While it exists the set cannot grow. While run() is
    running (the progress callback may call back), closing the optimizer,
    its estimator or anything they use raises RuntimeError.
    """

    _destroy_name = "optimizer_destroy"
    param_bounds = staticmethod(optimizer_param_bounds)
    _running = False

    def __init__(self, ctx, measurements, initial, **params):
        c = handle_arg(ctx, Context, "ctx")
        sp = handle_arg(measurements, Measurements, "measurements")
        mp = handle_arg(initial, Medium, "initial")
        h = ctypes.c_void_p()
        check(lib.optimizer_create(c, sp, mp, ctypes.byref(h)))
        super().__init__(h, [ctx])
        self.context = ctx
        self._borrow(measurements)
        measurements._optimizers.add(self)
        self._measurements = measurements
        self._initial = initial  # copied by the library; kept for the caller's convenience
        self._maps = []          # stage maps, in schedule order
        self._callback = None    # the CFUNCTYPE object: must live as long as the C pointer
        # The callback's exception, kept here until run() re-raises it. The
        # callback references this list, not the optimizer: no cycle.
        self._callback_box = [None]
        for name, value in params.items():
            self.set_param(name, value)

    @one_thread
    def set_param(self, param, value):
        p = lookup(param, OPTIMIZER_PARAMS, "optimizer parameter")
        if p == OPTIMIZER_PARAMS["method"]:
            value = lookup(value, METHODS, "method")
        elif p == OPTIMIZER_PARAMS["coordinates"]:
            value = lookup(value, COORDINATES, "coordinates")
        check(lib.optimizer_set_param(self._ptr, p, number(value, "value")))
        return self

    @one_thread
    def get_param(self, param):
        v = ctypes.c_double()
        check(lib.optimizer_get_param(self._ptr, lookup(param, OPTIMIZER_PARAMS,
                                                        "optimizer parameter"), ctypes.byref(v)))
        return v.value

    @one_thread
    def set_bounds(self, param, lo, hi):
        """Box of one physical parameter ("sigma_a", "sigma_s", "g"); hi may be float("inf")."""
        check(lib.optimizer_set_bounds(self._ptr, param_id(param), number(lo, "lo"),
                                       number(hi, "hi")))
        return self

    @one_thread
    def add_stage(self, param_map, iterations=0, frozen=None, value_mask=None, epsilon_start=0.0,
                  average_window=0, settle_epsilon=0.0, settle_fraction=0.0, settle_photons=0.0):
        """Append a stage on `param_map`. frozen: param_map.size flags
        (true = entry kept fixed); value_mask: value_count flags (false =
        value left out). iterations 0: the "iterations" tunable. epsilon_start:
        ADADELTA's relative epsilon at the stage's start, falling linearly to
        the "epsilon" tunable over its first half; 0: the tunable throughout.
        average_window: the trailing iterates the stage's result averages
        (at most the "average_window" tunable); 0: that tunable, or the
        settling part. settle_epsilon: ADADELTA's relative epsilon over the
        stage's last settle_fraction of iterations (0: the stage's own).
        Under SGD, AdaGrad and Adam both scale "learning_rate" by their
        epsilon over the "epsilon" tunable. settle_photons: the estimator's
        photons over that part, times its "photons" tunable (0: none)."""
        me = self._ptr
        handle_arg(param_map, ParamMap, "param_map")
        f = _mask_bytes(frozen, param_map.size, "frozen")
        m = _mask_bytes(value_mask, self._measurements.value_count, "value_mask")
        stage = _structs_stage(param_map, integer(iterations, "iterations"), f, m, number(epsilon_start, "epsilon_start"),
                               integer(average_window, "average_window"), number(settle_epsilon, "settle_epsilon"),
                               number(settle_fraction, "settle_fraction"), number(settle_photons, "settle_photons"))
        check(lib.optimizer_add_stage(me, ctypes.byref(stage)))
        self._borrow(param_map)
        self._maps.append(param_map)
        return self

    @one_thread
    def add_layerwise_stages(self, param_map, layer_thickness, layers, iterations=0):
        """Append the layer-wise stages of the paper's Fig. 2(b) (identity map,
        pathlength-resolved frontlit rows)."""
        pm = handle_arg(param_map, ParamMap, "param_map")
        layers = integer(layers, "layers")
        check(lib.optimizer_add_layerwise_stages(self._ptr, pm,
                                                 number(layer_thickness, "layer_thickness"),
                                                 layers, integer(iterations, "iterations")))
        self._borrow(param_map)
        self._maps.extend([param_map] * layers)
        return self

    @one_thread
    def set_progress(self, fn):
        """Call fn(Progress) after every iteration; a true return value stops
        the run (stop reason "callback"). An exception raised by fn stops
        the run too and is re-raised by run(). None removes the callback."""
        me = self._ptr
        if fn is None:
            check(lib.optimizer_set_progress(me, PROGRESS_FN(), None))
            self._callback = None
            return self
        if not callable(fn):
            raise TypeError("fn: expected a callable or None, got %s" % type(fn).__name__)
        box = self._callback_box

        def trampoline(progress, _user):
            try:
                p = progress.contents
                return 1 if fn(Progress(p.stage, p.stage_count, p.iteration, p.stage_iteration,
                                        p.stage_iterations, p.total_iterations, p.loss, p.step,
                                        p.elapsed)) else 0
            except BaseException as e:  # never unwind through C
                if box[0] is None:
                    box[0] = e
                return 1

        cb = PROGRESS_FN(trampoline)
        check(lib.optimizer_set_progress(me, cb, None))
        self._callback = cb
        return self

    @one_thread
    def set_checkpoint(self, path):
        """Write checkpoints to `path` during runs (None: stop)."""
        check(lib.optimizer_set_checkpoint(self._ptr, None if path is None else _path(path)))
        return self

    @one_thread
    def save(self, path):
        check(lib.optimizer_save(self._ptr, _path(path)))

    @one_thread
    def resume(self, path):
        """Restore a checkpoint written by an identically configured optimizer."""
        self._not_running("resume")
        check(lib.optimizer_resume(self._ptr, _path(path)))
        return self

    @one_thread
    def run(self, estimator):
        """Run the schedule; returns why it ended: "completed", "time_budget"
        or "callback"."""
        ep = handle_arg(estimator, Estimator, "estimator")
        me = self._ptr
        self._not_running("run")
        reason = ctypes.c_int32()
        box = self._callback_box
        box[0] = None
        running_callback = self._callback  # alive even if the callback replaces itself
        self._running = True
        try:
            with exclusive(estimator), pinned(self, estimator):  # the run renders with it
                rc = lib.optimizer_run(me, ep, ctypes.byref(reason))
        finally:
            self._running = False
            del running_callback
        err, box[0] = box[0], None
        if err is not None:
            try:
                raise err
            finally:
                err = None  # no frame -> exception -> traceback -> frame cycle
        check(rc)
        return STOP_REASONS.get(reason.value, reason.value)

    def _not_running(self, what):
        if self._running:
            raise RuntimeError("Optimizer.%s: the optimizer is running (called from its "
                               "progress callback?)" % what)

    @one_thread
    def result(self):
        """The current estimate as a new committed Medium."""
        h = ctypes.c_void_p()
        check(lib.optimizer_result(self._ptr, ctypes.byref(h)))
        return Medium._adopt_new(h, self.context)

    @one_thread
    def get_pi(self, averaged=True):
        """The current stage's π: the trailing average or the last iterate."""
        sizes = []
        for m in reversed(self._maps):
            if m.size not in sizes:
                sizes.append(m.size)
        error = None
        for k in sizes or [0]:
            out, ptr = _arrays.empty(k)
            rc = lib.optimizer_get_pi(self._ptr, 1 if averaged else 0, ptr, k)
            if rc == 0:
                return out
            try:
                check(rc)
            except HetinvError as e:  # a count of another stage: try the next size
                error = e
                if rc != 2:
                    raise
        raise error

    @one_thread
    def losses(self):
        """The loss of every iteration run so far."""
        n = ctypes.c_size_t()
        ptr = lib.optimizer_losses(self._ptr, ctypes.byref(n))
        return _arrays.copy_from(ptr, n.value if ptr else 0)


def _structs_stage(param_map, iterations, frozen, value_mask, epsilon_start, average_window, settle_epsilon,
                   settle_fraction, settle_photons):
    from ._structs import Stage

    s = Stage()
    s.map = param_map._ptr
    s.iterations = iterations
    s.frozen = frozen.ptr
    s.value_mask = value_mask.ptr
    s.epsilon_start = epsilon_start
    s.average_window = average_window
    s.settle_epsilon = settle_epsilon
    s.settle_fraction = settle_fraction
    s.settle_photons = settle_photons
    return s
