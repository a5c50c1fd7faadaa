"""ctypes mirrors of the public C structs.

The size-prefixed structs (those whose first member is `size_t size`) get
their size set on construction; those with a C default function
(hetinv_noise_model_default, ...) are filled by it, so a Python caller starts
from exactly the library's defaults and changes what it names. Field names
and order follow the headers; tests/python/test_structs.py compares every
sizeof with the C compiler's.
"""
import ctypes

_d3 = ctypes.c_double * 3
_d6 = ctypes.c_double * 6

# ctypes wraps an integer that does not fit a field; these are checked first.
_INT_FIELDS = {ctypes.c_int32: "int32", ctypes.c_uint32: "uint32", ctypes.c_uint64: "uint64",
               ctypes.c_size_t: "size_t"}


def _checked(ctype, value, name):
    from ._args import integer, number  # late: _args is tiny, but keep import order simple

    if ctype in _INT_FIELDS:
        return integer(value, name, _INT_FIELDS[ctype])
    if ctype is ctypes.c_double:
        return number(value, name)
    return value


class _Sized(ctypes.Structure):
    """A struct whose first member is its own size."""

    _default_fn = None  # name of the C function that fills the defaults, if any

    def __init__(self, **fields):
        super().__init__()
        if self._default_fn is not None:
            from ._lib import lib  # late: _lib imports this module

            getattr(lib, self._default_fn[len("hetinv_"):])(ctypes.byref(self))
        super().__setattr__("size", ctypes.sizeof(self))
        for name, value in fields.items():
            setattr(self, name, value)

    def __setattr__(self, name, value):
        if not name.startswith("_") and not hasattr(type(self), name):
            raise AttributeError("%s has no field %r" % (type(self).__name__, name))
        if name == "size":  # the library reads as many bytes as it says
            raise AttributeError("%s.size is set by the binding" % type(self).__name__)
        ctype = dict(self._fields_).get(name)
        label = "%s.%s" % (type(self).__name__, name)
        if ctype is not None and issubclass(ctype, ctypes.Array):
            current = getattr(self, name)
            value = list(value)
            if len(value) != len(current):
                raise ValueError("%s takes %d values, not %d" % (label, len(current), len(value)))
            current[:] = [_checked(ctype._type_, v, "%s[%d]" % (label, i))
                          for i, v in enumerate(value)]
            return
        if ctype is not None:
            value = _checked(ctype, value, label)
        super().__setattr__(name, value)

    def as_dict(self):
        """The fields as a plain dict (arrays as lists)."""
        out = {}
        for name, _ in self._fields_:
            v = getattr(self, name)
            out[name] = list(v) if isinstance(v, ctypes.Array) else v
        return out

    def __repr__(self):
        return "%s(%s)" % (type(self).__name__,
                           ", ".join("%s=%r" % kv for kv in self.as_dict().items() if kv[0] != "size"))


class ContextInit(_Sized):
    """hetinv_context_init_t (HETINV_CONTEXT_INIT_DEFAULT is all zeros but size)."""

    _fields_ = [
        ("size", ctypes.c_size_t),
        ("alloc_fn", ctypes.c_void_p),
        ("free_fn", ctypes.c_void_p),
        ("alloc_user_data", ctypes.c_void_p),
        ("error_fn", ctypes.c_void_p),
        ("error_user_data", ctypes.c_void_p),
        ("thread_count", ctypes.c_int32),
        ("seed", ctypes.c_uint64),
    ]


class VolHeader(ctypes.Structure):
    """hetinv_vol_header_t: dims, channels and bounding box of a .vol file."""

    _fields_ = [
        ("dims", ctypes.c_int32 * 3),
        ("channels", ctypes.c_int32),
        ("box_min", _d3),
        ("box_max", _d3),
    ]

    def __repr__(self):
        return "VolHeader(dims=%r, channels=%d, box_min=%r, box_max=%r)" % (
            list(self.dims), self.channels, list(self.box_min), list(self.box_max))


class RenderStats(_Sized):
    """hetinv_render_stats_t: statistics of the last render."""

    _fields_ = [
        ("size", ctypes.c_size_t),
        ("photons", ctypes.c_uint64),
        ("seconds", ctypes.c_double),
        ("specular", ctypes.c_double),
        ("absorbed", ctypes.c_double),
        ("absorbed_std_error", ctypes.c_double),
        ("escaped", _d6),
        ("escaped_std_error", _d6),
        ("truncated", ctypes.c_double),
        ("truncated_paths", ctypes.c_uint64),
    ]


class Stage(_Sized):
    """hetinv_stage_t (internal: Optimizer.add_stage builds it)."""

    _fields_ = [
        ("size", ctypes.c_size_t),
        ("map", ctypes.c_void_p),
        ("iterations", ctypes.c_int32),
        ("frozen", ctypes.POINTER(ctypes.c_uint8)),
        ("value_mask", ctypes.POINTER(ctypes.c_uint8)),
        ("epsilon_start", ctypes.c_double),
        ("average_window", ctypes.c_int32),
        ("settle_epsilon", ctypes.c_double),
        ("settle_fraction", ctypes.c_double),
        ("settle_photons", ctypes.c_double),
    ]


class Progress(ctypes.Structure):
    """hetinv_progress_t, as the library passes it to the progress callback."""

    _fields_ = [
        ("size", ctypes.c_size_t),
        ("stage", ctypes.c_int32),
        ("stage_count", ctypes.c_int32),
        ("iteration", ctypes.c_int64),
        ("stage_iteration", ctypes.c_int64),
        ("stage_iterations", ctypes.c_int64),
        ("total_iterations", ctypes.c_int64),
        ("loss", ctypes.c_double),
        ("step", ctypes.c_double),
        ("elapsed", ctypes.c_double),
    ]


class NoiseModel(_Sized):
    """hetinv_noise_model_t, initialised by hetinv_noise_model_default().

    NoiseModel(read_noise=2.0, seed=7) starts from the library's defaults
    (full well 20000, read noise 5, automatic exposure at 0.9 of the well).
    """

    _default_fn = "hetinv_noise_model_default"
    _fields_ = [
        ("size", ctypes.c_size_t),
        ("full_well", ctypes.c_double),
        ("read_noise", ctypes.c_double),
        ("exposure", ctypes.c_double),
        ("auto_level", ctypes.c_double),
        ("seed", ctypes.c_uint64),
        ("first_index", ctypes.c_uint64),
    ]


class MixtureSpec(_Sized):
    """hetinv_mixture_spec_t, initialised by hetinv_mixture_spec_default().

    lo and hi are indexed by parameter (sigma_a, sigma_s, g).
    """

    _default_fn = "hetinv_mixture_spec_default"
    _fields_ = [
        ("size", ctypes.c_size_t),
        ("lo", _d3),
        ("hi", _d3),
        ("components", ctypes.c_int32),
        ("min_width", ctypes.c_double),
        ("max_width", ctypes.c_double),
        ("constant_axis", ctypes.c_int32),
        ("seed", ctypes.c_uint64),
    ]


class SmokeSpec(_Sized):
    """hetinv_smoke_spec_t, initialised by hetinv_smoke_spec_default()."""

    _default_fn = "hetinv_smoke_spec_default"
    _fields_ = [
        ("size", ctypes.c_size_t),
        ("lo", _d3),
        ("hi", _d3),
        ("octaves", ctypes.c_int32),
        ("feature_size", ctypes.c_double),
        ("seed", ctypes.c_uint64),
    ]
