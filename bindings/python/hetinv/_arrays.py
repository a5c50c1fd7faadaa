"""Arrays in and out: numpy when it is importable, array.array otherwise.

Inputs may be any sequence of numbers, an array.array or a numpy array,
read in C order; where the caller knows the input's shape (a grid's
(nz, ny, nx)), a numpy array of more than one axis must have it. A numpy array that already has the C
type and is C-contiguous is passed to the library as it is, without a copy;
any other array is converted once. Outputs are numpy arrays when numpy is
available and enabled, else array.array('d') (or 'f' / 'B'). The library
writes its outputs straight into the returned array's buffer; per-voxel and
per-cell outputs are then reshaped (a view, no copy) to the grid's shape,
e.g. (nz, ny, nx): C order, so .ravel() is the library's linear order, x
fastest. array.array outputs are always flat. use_numpy(False) switches
numpy off, e.g. to test the pure-Python path.
"""
import array
import ctypes

try:
    import numpy as _np
except ImportError:  # numpy is optional
    _np = None

_enabled = _np is not None

_CTYPE = {"d": ctypes.c_double, "f": ctypes.c_float, "B": ctypes.c_uint8}
_NPTYPE = {"d": "float64", "f": "float32", "B": "uint8"}


def numpy_available():
    """True if numpy is importable (whether or not it is enabled)."""
    return _np is not None


def use_numpy(flag=True):
    """Return numpy arrays (True, the default when numpy is importable) or
    array.array (False). Returns the previous setting."""
    global _enabled
    previous = _enabled
    if flag and _np is None:
        raise ImportError("numpy is not importable")
    _enabled = bool(flag)
    return previous


def numpy_enabled():
    return _enabled


class CArray:
    """A contiguous C array made from a Python value, with what keeps its
    memory alive. .ptr is a POINTER(ctype), .count the number of items."""

    __slots__ = ("ptr", "count", "_keep")

    def __init__(self, ptr, count, keep):
        self.ptr, self.count, self._keep = ptr, count, keep


_FLOAT32_MAX = 3.4028234663852886e38


def _beyond_float32(values, name):
    """A ValueError for the first finite value past float32's range (it
    would become inf, and the library would name inf, not the value)."""
    for v in values:
        if abs(v) > _FLOAT32_MAX and abs(v) != float("inf"):
            raise ValueError("%s: %r is beyond float32's range" % (name, float(v)))


def _check_shape(values, shape, name):
    """A numpy array of more than one axis must have `shape` (singleton
    axes aside): read flat in C order, any other shape of the same size
    would be silently transposed (an (nx, ny, nz) grid for (nz, ny, nx))."""
    if shape is None or values.ndim <= 1:
        return
    given = tuple(n for n in values.shape if n != 1)
    wanted = tuple(n for n in shape if n != 1)
    if given != wanted:
        raise ValueError("%s: an array of shape %s where %s is expected (read in C order, it would "
                         "be reinterpreted; give it in that shape, or flat)"
                         % (name, tuple(values.shape), tuple(shape)))


def _refuse_unreadable(values, name, expected="numbers"):
    """A numpy array whose values would be guessed at, refused: a masked
    array's mask would be dropped, strings parsed as numbers, complex
    values cut to their real part."""
    if isinstance(values, _np.ma.MaskedArray):
        raise TypeError("%s: a masked array; its mask would be ignored: pass a.filled(value) or "
                        "a.compressed()" % name)
    if values.dtype.kind == "c":
        raise TypeError("%s: complex values (dtype %s); expected real numbers" % (name, values.dtype))
    if values.dtype.kind not in "biuf":
        raise TypeError("%s: values of dtype %s; expected %s" % (name, values.dtype, expected))


def to_c(values, typecode="d", count=None, name="values", shape=None):
    """C array of `typecode` items from `values` (None gives a NULL pointer).
    `count`, when given, is the number of items required: give it whenever
    the C function reads a fixed number of items without being told how
    many (a ValueError naming `name` otherwise). `shape`, when given, is the
    shape a numpy array of more than one axis must have."""
    ctype = _CTYPE[typecode]
    if values is None:
        return CArray(None, 0, None)
    if _np is not None and isinstance(values, _np.ndarray):
        # Refused where numpy would only warn or guess (_refuse_unreadable),
        # or where a float64 past float32's range would become inf.
        if values.dtype.kind == "O" and not isinstance(values, _np.ma.MaskedArray):
            values = values.astype(_np.float64)  # numbers as Python objects: through doubles, range checked
        _refuse_unreadable(values, name)
        _check_shape(values, shape, name)
        if typecode == "f" and values.dtype.kind == "f" and values.size:
            finite = values[_np.isfinite(values)]
            big = finite[_np.abs(finite) > _np.finfo(_np.float32).max]
            if big.size:
                raise ValueError("%s: %r is beyond float32's range" % (name, float(big.reshape(-1)[0])))
        arr = _np.ascontiguousarray(values, dtype=_NPTYPE[typecode]).reshape(-1)
        n = arr.size
        ptr = arr.ctypes.data_as(ctypes.POINTER(ctype))
        keep = arr
    else:
        if isinstance(values, array.array) and values.typecode == typecode:
            arr = values
        else:
            if isinstance(values, (bytes, bytearray)) and typecode != "B":
                raise TypeError("%s: expected numbers, got %s" % (name, type(values).__name__))
            try:
                if typecode == "f":  # through doubles, so that the range is checked, not cast
                    wide = array.array("d", values)
                    _beyond_float32(wide, name)
                    values = wide
                arr = array.array(typecode, values)
            except TypeError as x:  # a scalar, a nested list, a string inside
                raise TypeError("%s: expected a flat sequence of numbers (or a numpy array), got %s: %s"
                                % (name, type(values).__name__, x)) from None
        n = len(arr)
        if n == 0:
            buf = (ctype * 1)()
        else:
            addr, _ = arr.buffer_info()
            buf = (ctype * n).from_address(addr)
        ptr = ctypes.cast(buf, ctypes.POINTER(ctype))
        keep = (arr, buf)
    if count is not None and n != count:
        raise ValueError("%s: expected %d values, got %d" % (name, count, n))
    return CArray(ptr, n, keep)


def flags(mask, count=None, name="mask"):
    """A C array of 0/1 bytes from truthy/falsy items: any non-zero number
    is 1, as in C (256 must not wrap to 0). Strings and masked arrays are
    refused rather than guessed at ('0' is a truthy string)."""
    if mask is None:
        return to_c(None)
    if _np is not None and isinstance(mask, _np.ndarray):
        _refuse_unreadable(mask, name, "numbers or booleans")
        mask = (mask != 0).astype("uint8")
    elif not isinstance(mask, (bytes, bytearray)):
        items = list(mask)
        for m in items:
            if isinstance(m, (str, bytes)):
                raise TypeError("%s: %r; expected numbers or booleans" % (name, m))
        mask = [1 if m else 0 for m in items]
    return to_c(mask, "B", count, name)


def is_numpy(values):
    return _np is not None and isinstance(values, _np.ndarray)


def flat(values):
    """`values` in linear order: a 1-D view of a numpy array (a copy only if
    it is not contiguous), anything else as it is. Gives code that indexes
    outputs flat one spelling for both the numpy and the array.array path."""
    if _np is not None and isinstance(values, _np.ndarray):
        return values.reshape(-1)
    return values


def shaped(values, shape):
    """A numpy array reshaped to `shape` (a view); anything else as it is."""
    if shape is not None and _np is not None and isinstance(values, _np.ndarray):
        return values.reshape(shape)
    return values


def empty(count, typecode="d", shape=None):
    """A zeroed output array of `count` items and a pointer to its data. With
    numpy, the array is reshaped to `shape` (if given) after the pointer is
    taken: the pointer addresses the same buffer, in C order."""
    ctype = _CTYPE[typecode]
    if _enabled:
        arr = _np.zeros(count, dtype=_NPTYPE[typecode])
        return shaped(arr, shape), arr.ctypes.data_as(ctypes.POINTER(ctype))
    arr = array.array(typecode, bytes(ctypes.sizeof(ctype) * count))
    if count == 0:
        return arr, ctypes.cast((ctype * 1)(), ctypes.POINTER(ctype))
    return arr, ctypes.cast((ctype * count).from_address(arr.buffer_info()[0]),
                            ctypes.POINTER(ctype))


def copy_from(ptr, count, typecode="d", shape=None):
    """A new output array holding a copy of `count` items at `ptr` (memory
    the library owns and may change or free: never handed out as a view)."""
    out, dst = empty(count, typecode, shape)
    if count:
        ctypes.memmove(dst, ptr, count * ctypes.sizeof(_CTYPE[typecode]))
    return out


def fixed(values, n, typecode, name):
    """A ctypes array of exactly n items (a vector argument such as an origin)."""
    if values is None:
        return None
    from ._args import integer, number

    vals = list(values.tolist() if hasattr(values, "tolist") else values)
    if len(vals) != n:
        raise ValueError("%s: expected %d values, got %d" % (name, n, len(vals)))
    if typecode == "i":  # ctypes would wrap an int32 that does not fit
        return (ctypes.c_int32 * n)(*[integer(v, "%s[%d]" % (name, i)) for i, v in enumerate(vals)])
    return (_CTYPE[typecode] * n)(*[number(v, "%s[%d]" % (name, i)) for i, v in enumerate(vals)])
