"""Scalar arguments checked before ctypes converts them.

ctypes silently wraps an integer that does not fit its C type
(set_voxel(2**32, ...) would write voxel 0) and truncates a float passed
as an enum through int(); these helpers raise instead, naming the
parameter: TypeError for a value of the wrong kind, OverflowError for an
integer outside the C type's range.
"""
import numbers
import operator

_RANGES = {
    "int32": (-2**31, 2**31 - 1),
    "uint32": (0, 2**32 - 1),
    "int": (-2**31, 2**31 - 1),
    "uint64": (0, 2**64 - 1),
    "size_t": (0, 2**64 - 1),
}


def integer(value, name, ctype="int32"):
    """`value` as a Python int that fits C type `ctype` ("int32", "uint32",
    "uint64", "size_t"). Accepts ints and integer-like objects (numpy
    integers); rejects floats, strings and booleans (img[True] would be
    channel 1, set_bounds(True, ...) the bounds of sigma_s)."""
    if isinstance(value, (float, str, bytes, bool)) or type(value).__name__ == "bool_":
        raise TypeError("%s: expected an integer, got %s %r" % (name, type(value).__name__, value))
    try:
        v = operator.index(value)
    except TypeError:
        raise TypeError("%s: expected an integer, got %s" % (name, type(value).__name__)) from None
    lo, hi = _RANGES[ctype]
    if not lo <= v <= hi:
        raise OverflowError("%s: %d is outside the range of %s (%d to %d)"
                            % (name, v, ctype, lo, hi))
    return v


def number(value, name):
    """`value` as a float (for a C double): a real number (a 0-d numpy array
    of one included, as np.mean(..., keepdims) or a[()] give), not a string
    or None."""
    kind = getattr(getattr(value, "dtype", None), "kind", None)
    if getattr(value, "ndim", None) == 0 and kind is not None and kind in "iuf":
        value = value.item()
    if isinstance(value, (str, bytes)) or not isinstance(value, numbers.Real):
        raise TypeError("%s: expected a number, got %s %r" % (name, type(value).__name__, value))
    try:
        return float(value)
    except OverflowError:
        raise OverflowError("%s: %r is too large for a double" % (name, value)) from None


def path(value, name="path"):
    """A file path as bytes for a C string. A NUL byte would end the C
    string early (writing another file than the one named), so it is a
    ValueError, as in open()."""
    import os

    b = os.fsencode(value)
    if b"\0" in b:
        raise ValueError("%s: embedded null byte in %r" % (name, value))
    return b
