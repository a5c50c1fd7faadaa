"""Images (io.h): float32 channels of one size with named attributes, read
from and written to OpenEXR, drawn as PNG previews. Every map the programs
write (recovered parameters, errors, the bound, measured images) is such a
file, so a script reads them here without an OpenEXR module of its own:

    img = hetinv.read_exr(ctx, "out/bound.exr")
    sd = img["bound_sigma_a"]          # (height, width) float32 array
    img.attributes["hetinv:key"]
"""
import ctypes
import numbers

from . import _arrays
from ._args import integer, number, path as _path
from ._errors import check
from ._handle import Handle, handle_arg
from ._lib import lib
from ._names import lookup

ATTRIBUTE_STRING, ATTRIBUTE_DOUBLE, ATTRIBUTE_INT = 0, 1, 2
COLORMAP_GRAY, COLORMAP_VIRIDIS = 0, 1
COLORMAPS = {"gray": 0, "viridis": 1}


def _ctx(ctx):
    from .context import Context

    return handle_arg(ctx, Context, "ctx")


def _text(value, name):
    """A str as UTF-8 bytes for a C string. A NUL byte would end the C
    string early (naming another channel or attribute than the one
    given), so it is a ValueError, as for paths."""
    if not isinstance(value, str):
        raise TypeError("%s: expected a str, got %s" % (name, type(value).__name__))
    if "\0" in value:
        raise ValueError("%s: embedded null character in %r" % (name, value))
    return value.encode()


class Image(Handle):
    """hetinv_image_t: `channels` channels of width × height float32 pixels,
    all 0, named "c0", "c1", ... Pixel (x, y) of a channel is its
    array's [y, x], row 0 at the top. Channels are addressed by index or
    by name; their arrays are copies (set them back with set_channel)."""

    _destroy_name = "image_destroy"

    def __init__(self, ctx, width, height, channels=1):
        h = ctypes.c_void_p()
        check(lib.image_create(_ctx(ctx), integer(width, "width"), integer(height, "height"),
                               integer(channels, "channels"), ctypes.byref(h)))
        super().__init__(h, [ctx])
        self.context = ctx

    @property
    def size(self):
        """(width, height, channel count)."""
        w, h, c = ctypes.c_int32(), ctypes.c_int32(), ctypes.c_int32()
        check(lib.image_get_size(self._ptr, ctypes.byref(w), ctypes.byref(h), ctypes.byref(c)))
        return w.value, h.value, c.value

    @property
    def channel_names(self):
        return [lib.image_channel_name(self._ptr, i).decode() for i in range(self.size[2])]

    def channel_index(self, channel):
        """The index of a channel given by index or name (KeyError or
        IndexError if there is none)."""
        if isinstance(channel, str):
            index = ctypes.c_int32()
            if lib.image_find_channel(self._ptr, _text(channel, "channel"), ctypes.byref(index)) != 0:
                raise KeyError("no channel %r; the image has %s"
                               % (channel, ", ".join(self.channel_names)))
            return index.value
        i = integer(channel, "channel")
        n = self.size[2]
        if not 0 <= i < n:
            raise IndexError("channel %d is out of range; the image has %d" % (i, n))
        return i

    def channel(self, channel):
        """A copy of one channel's pixels, shape (height, width) with numpy."""
        w, h, _ = self.size
        ptr = lib.image_channel_data(self._ptr, self.channel_index(channel))
        return _arrays.copy_from(ptr, w * h, "f", (h, w))

    __getitem__ = channel

    def set_channel(self, channel, values):
        """Overwrite one channel with width·height numbers (rounded to
        float32): flat, row 0 first, or a numpy array of shape (height, width)."""
        w, h, _ = self.size
        i = self.channel_index(channel)
        src = _arrays.to_c(values, "f", w * h, "values", shape=(h, w))
        ctypes.memmove(lib.image_channel_data(self._ptr, i), src.ptr, w * h * 4)
        return self

    def rename_channel(self, channel, name):
        check(lib.image_set_channel_name(self._ptr, self.channel_index(channel), _text(name, "name")))
        return self

    @property
    def attributes(self):
        """A new dict of the attributes: str, float or int values, in the
        order they were set or read."""
        out = {}
        for i in range(lib.image_attribute_count(self._ptr)):
            name, kind = ctypes.c_char_p(), ctypes.c_int32()
            check(lib.image_attribute_at(self._ptr, i, ctypes.byref(name), ctypes.byref(kind)))
            out[name.value.decode()] = self._attribute(name.value, kind.value)
        return out

    def _attribute(self, name, kind):
        if kind == ATTRIBUTE_STRING:
            s = ctypes.c_char_p()
            check(lib.image_get_attribute_string(self._ptr, name, ctypes.byref(s)))
            return s.value.decode("utf-8", "replace")
        if kind == ATTRIBUTE_INT:
            v = ctypes.c_int32()
            check(lib.image_get_attribute_int(self._ptr, name, ctypes.byref(v)))
            return v.value
        d = ctypes.c_double()
        check(lib.image_get_attribute_double(self._ptr, name, ctypes.byref(d)))
        return d.value

    def set_attribute(self, name, value):
        """Add or replace an attribute: a str is stored as a string, an int
        (which must fit int32) as an int, any other real number as a double."""
        key = _text(name, "name")
        if isinstance(value, str):
            check(lib.image_set_attribute_string(self._ptr, key, _text(value, name)))
        elif isinstance(value, numbers.Integral) and not isinstance(value, bool):  # numpy ints too
            check(lib.image_set_attribute_int(self._ptr, key, integer(value, name)))
        else:
            check(lib.image_set_attribute_double(self._ptr, key, number(value, name)))
        return self

    def write_exr(self, path):
        """Write as a float32 OpenEXR file with the attributes (atomic)."""
        check(lib.image_write_exr(self._ptr, _path(path)))

    def write_png(self, channel, path, lo=0.0, hi=0.0, colormap="viridis"):
        """An 8-bit false-colour preview of one channel (atomic); [lo, hi]
        maps onto the colour map, lo == hi: the channel's finite range."""
        check(lib.image_write_png(self._ptr, self.channel_index(channel), _path(path),
                                  number(lo, "lo"), number(hi, "hi"),
                                  lookup(colormap, COLORMAPS, "colormap")))


def read_exr(ctx, path):
    """A single-part OpenEXR file as an Image (channels converted to
    float32, their order as written by the library restored; the data window
    must be the display window)."""
    h = ctypes.c_void_p()
    check(lib.image_read_exr(_ctx(ctx), _path(path), ctypes.byref(h)))
    img = Image._wrap(h, [ctx])
    img.context = ctx
    return img
