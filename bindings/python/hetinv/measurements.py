"""Measurement sets: rows of (emitter, sensor, pathlength), their measured
values, weights and mask (measurement.h)."""
import ctypes
import weakref

from . import _arrays
from ._args import integer, number
from ._errors import check
from ._handle import Handle, handle_arg, _lock as _handle_lock
from ._lib import lib


class Measurements(Handle):
    """hetinv_measurements_t. The C set borrows its rows' emitters, sensors
    and pathlengths: this object keeps them alive, and closing one of them
    closes the set first. A set an optimizer uses cannot grow (the
    optimizer's stage masks have one byte per value it had)."""

    _destroy_name = "measurements_destroy"

    def __init__(self, ctx):
        from .context import Context

        c = handle_arg(ctx, Context, "ctx")
        h = ctypes.c_void_p()
        check(lib.measurements_create(c, ctypes.byref(h)))
        super().__init__(h, [ctx])
        self.context = ctx
        self._optimizers = weakref.WeakSet()  # the optimizers made for this set
        self._sizes = []  # (width, height) of each row's sensor, for row_shape

    def add(self, emitter, sensor, pathlength=None):
        """Append a row; returns its index. pathlength None: a steady-state
        window made for this set."""
        from .sampling import Emitter, Pathlength, Sensor

        me = self._ptr
        ep = handle_arg(emitter, Emitter, "emitter")
        sp = handle_arg(sensor, Sensor, "sensor")
        if pathlength is not None:
            pp = handle_arg(pathlength, Pathlength, "pathlength")
        self._unused("add a row to")
        if pathlength is None:
            pathlength = self.__dict__.get("_steady")
            if pathlength is None or pathlength.closed:
                pathlength = self._steady = Pathlength.steady(self.context)
            pp = pathlength._ptr
        row = ctypes.c_int32()
        with _handle_lock:  # adding reallocates the rows: not while a render reads them
            if self._owner.busy:
                raise RuntimeError("cannot add a row to a measurement set a running render uses")
            check(lib.measurements_add(me, ep, sp, pp, ctypes.byref(row)))
        self._borrow(emitter, sensor, pathlength)
        self._sizes.append(sensor.size)
        return row.value

    @property
    def row_count(self):
        return lib.measurements_row_count(self._ptr)

    @property
    def value_count(self):
        return lib.measurements_value_count(self._ptr)

    def __len__(self):
        return self.value_count

    def layout(self, row):
        """(offset, pixels, bins) of a row: value (pixel p, bin b) is at offset + b·pixels + p."""
        off, px, bins = ctypes.c_size_t(), ctypes.c_int32(), ctypes.c_int32()
        check(lib.measurements_row_layout(self._ptr, integer(row, "row"), ctypes.byref(off),
                                          ctypes.byref(px),
                                          ctypes.byref(bins)))
        return off.value, px.value, bins.value

    def _offset_shape(self, row):
        offset, pixels, bins = self.layout(row)
        width, height = self._sizes[row]
        if width * height != pixels:  # cannot happen: rows are added through add()
            raise RuntimeError("row %d: sensor %d x %d, layout %d pixels" % (row, width, height,
                                                                               pixels))
        return offset, (bins, height, width)

    def row_shape(self, row):
        """(bins, height, width) of a row: the numpy shape of its values, so
        that value [b, j, i] is pixel (i, j) (index j·width + i) in bin b."""
        return self._offset_shape(row)[1]

    def _row_layouts(self):
        """[(offset, (bins, height, width))] of every row."""
        return [self._offset_shape(r) for r in range(self.row_count)]

    def row(self, values, row):
        """Row `row` of `values` (value_count items, e.g. self.values or a
        render's values): with numpy a view of shape row_shape(row), else a
        flat slice."""
        values = _arrays.flat(values)
        offset, shape = self._offset_shape(row)
        if len(values) != self.value_count:
            raise ValueError("values: expected %d values, got %d" % (self.value_count,
                                                                   len(values)))
        return _arrays.shaped(values[offset:offset + shape[0] * shape[1] * shape[2]], shape)

    def _unused(self, what):
        """The C set must not change while an optimizer made for it exists
        (hetinv_optimizer_create): its masks and checkpoints describe it.
        A change from a progress callback altered a run from the next
        iteration on."""
        if any(not o.closed for o in self._optimizers):
            raise RuntimeError("cannot %s a measurement set an optimizer uses (close the optimizer first)" % what)

    def set_values(self, values, std_errors=None):
        self._unused("set the values of")
        v = _arrays.to_c(values, "d", name="values")
        e = _arrays.to_c(std_errors, "d", None if std_errors is None else v.count, "std_errors")
        check(lib.measurements_set_values(self._ptr, v.ptr, e.ptr, v.count))
        return self

    def set_weights(self, weights):
        self._unused("set the weights of")
        w = _arrays.to_c(weights, "d", name="weights")
        check(lib.measurements_set_weights(self._ptr, w.ptr, w.count))
        return self

    def set_clip_scales(self, below=None, above=None):
        """below, above: value_count numbers > 0 by which Huber's clip
        (Estimator loss_clip) of each value is multiplied where the render
        is below the data and where it is above (None: 1)."""
        if below is None and above is None:
            raise ValueError("set_clip_scales: give below, above or both")
        self._unused("set the clip scales of")
        b = _arrays.to_c(below, "d", name="below")
        a = _arrays.to_c(above, "d", b.count if below is not None else None, "above")
        count = b.count if below is not None else a.count
        check(lib.measurements_set_clip_scales(self._ptr, b.ptr, a.ptr, count))
        return self

    def set_mask(self, mask):
        """mask: value_count truthy/falsy items (0 = left out of the loss)."""
        self._unused("set the mask of")
        m = _arrays.flags(mask, name="mask")  # any non-zero means "used", as in C
        check(lib.measurements_set_mask(self._ptr, m.ptr, m.count))
        return self

    def mask_saturated(self, level):
        """Mask out (mask 0) every value whose measured value is at or above
        `level`, keeping the rest of the mask; returns how many values are
        at or above it."""
        self._unused("mask values of")
        n = ctypes.c_size_t()
        check(lib.measurements_mask_saturated(self._ptr, number(level, "level"), ctypes.byref(n)))
        return n.value

    def _copy(self, fn, typecode):
        n = self.value_count
        ptr = fn(self._ptr)
        return _arrays.copy_from(ptr, n if ptr else 0, typecode)

    @property
    def values(self):
        return self._copy(lib.measurements_values, "d")

    @property
    def std_errors(self):
        return self._copy(lib.measurements_std_errors, "d")

    @property
    def weights(self):
        return self._copy(lib.measurements_weights, "d")

    @property
    def clip_scales_below(self):
        return self._copy(lib.measurements_clip_scales_below, "d")

    @property
    def clip_scales_above(self):
        return self._copy(lib.measurements_clip_scales_above, "d")

    @property
    def mask(self):
        return self._copy(lib.measurements_mask, "B")
