"""Sampling functions: emitters, sensors, pathlength windows (sampling.h).

Emitters and sensors are made from a medium, whose box and refractive
indices they copy (they keep no pointer to it); all three are immutable.
Faces are 0..5 or "x_min" ... "z_max"; a point on a face is (u, v).
"""
import ctypes
import numbers as numbers_abc

from . import _arrays
from ._args import integer, number
from ._errors import check
from ._handle import Handle, handle_arg
from ._lib import lib
from ._names import FACES, WINDOWS, lookup


def _medium(medium):
    from .medium import Medium

    return handle_arg(medium, Medium, "medium")


def _ctx(ctx):
    from .context import Context

    return handle_arg(ctx, Context, "ctx")


def _from_medium(cls, h, medium):
    # made from the medium's context, which must outlive it; the medium itself is not borrowed
    obj = cls._wrap(h, [medium.context])
    obj.context = medium.context
    return obj


def face_id(face):
    return lookup(face, FACES, "face")


class Emitter(Handle):
    """hetinv_emitter_t. Make one with Emitter.ideal / area / diffuse / combination."""

    _destroy_name = "emitter_destroy"

    _made = classmethod(lambda cls, h, medium: _from_medium(cls, h, medium))

    @classmethod
    def ideal(cls, medium, origin, direction):
        """A collimated pencil beam from `origin` (outside the box) along `direction`."""
        h = ctypes.c_void_p()
        check(lib.emitter_create_ideal(_medium(medium), _arrays.fixed(origin, 3, "d", "origin"),
                                       _arrays.fixed(direction, 3, "d", "direction"),
                                       ctypes.byref(h)))
        return cls._made(h, medium)

    @classmethod
    def area(cls, medium, face, direction, rect_min, rect_max, pattern=None, pattern_shape=None):
        """A collimated area source on a face's rectangle. `pattern`: weights,
        u fastest, of shape pattern_shape = (width, height); a 2D numpy array
        of shape (height, width) needs no pattern_shape. None: uniform."""
        mp = _medium(medium)
        if pattern is None:
            w = hgt = 1
            pat = _arrays.to_c(None)
        else:
            if pattern_shape is None:
                shape = getattr(pattern, "shape", None)
                if shape is None or len(shape) != 2:
                    raise ValueError("pattern_shape=(width, height) is needed for a flat pattern")
                hgt, w = shape
            else:
                w, hgt = pattern_shape
            w, hgt = integer(w, "pattern width"), integer(hgt, "pattern height")
            if w < 0 or hgt < 0:
                raise ValueError("pattern_shape: (%d, %d) has a negative side" % (w, hgt))
            pat = _arrays.to_c(pattern, "d", w * hgt, "pattern", shape=(hgt, w))
        h = ctypes.c_void_p()
        check(lib.emitter_create_area(mp, face_id(face),
                                      _arrays.fixed(direction, 3, "d", "direction"),
                                      _arrays.fixed(rect_min, 2, "d", "rect_min"),
                                      _arrays.fixed(rect_max, 2, "d", "rect_max"), w, hgt,
                                      pat.ptr, ctypes.byref(h)))
        return cls._made(h, medium)

    @classmethod
    def diffuse(cls, medium, face, point):
        """A Lambertian point source at face coordinates `point`."""
        h = ctypes.c_void_p()
        check(lib.emitter_create_diffuse(_medium(medium), face_id(face),
                                         _arrays.fixed(point, 2, "d", "point"), ctypes.byref(h)))
        return cls._made(h, medium)

    @classmethod
    def combination(cls, medium, origins, directions, weights):
        """A weighted sum of pencil beams: origins and directions are lists
        of 3-vectors (or flat 3·n sequences), weights n powers."""
        mp = _medium(medium)
        w = _arrays.to_c(weights, "d", name="weights")
        o = _arrays.to_c(_flat(origins, "origins"), "d", 3 * w.count, "origins")
        d = _arrays.to_c(_flat(directions, "directions"), "d", 3 * w.count, "directions")
        h = ctypes.c_void_p()
        check(lib.emitter_create_combination(mp, integer(w.count, "len(weights)"), o.ptr, d.ptr,
                                             w.ptr, ctypes.byref(h)))
        return cls._made(h, medium)


def _flat(vectors, name):
    """3-vectors, or one flat sequence of 3·n numbers, as one flat sequence;
    a vector of another length is an error, not regrouped with the next."""
    if hasattr(vectors, "shape"):
        if len(vectors.shape) == 2 and vectors.shape[1] != 3:
            raise ValueError(f"{name}: an array of shape {tuple(vectors.shape)}; expected (n, 3) or flat")
        return vectors  # numpy: read in C order
    vectors = list(vectors)
    numbers = [isinstance(v, numbers_abc.Real) for v in vectors]
    if all(numbers):
        return vectors
    if any(numbers):
        raise ValueError(f"{name}: mixes numbers and vectors; give 3-vectors or one flat sequence")
    out = []
    for i, v in enumerate(vectors):
        v = list(v)
        if len(v) != 3:
            raise ValueError(f"{name}[{i}] has {len(v)} elements; expected a 3-vector")
        out.extend(v)
    return out


class Sensor(Handle):
    """hetinv_sensor_t. Make one with Sensor.orthographic, Sensor.hemispherical or Sensor.fiber."""

    _destroy_name = "sensor_destroy"

    @classmethod
    def orthographic(cls, medium, face, direction, origin, pixel_size, width, height):
        """A width × height pixel grid on a face seeing light that leaves it along `direction`."""
        h = ctypes.c_void_p()
        check(lib.sensor_create_orthographic(
            _medium(medium), face_id(face), _arrays.fixed(direction, 3, "d", "direction"),
            _arrays.fixed(origin, 2, "d", "origin"), _arrays.fixed(pixel_size, 2, "d", "pixel_size"),
            integer(width, "width"), integer(height, "height"), ctypes.byref(h)))
        return _from_medium(cls, h, medium)

    @classmethod
    def hemispherical(cls, medium, face, rect_min=None, rect_max=None):
        """All power leaving through a face's rectangle (the whole face if omitted)."""
        h = ctypes.c_void_p()
        check(lib.sensor_create_hemispherical(_medium(medium), face_id(face),
                                              _arrays.fixed(rect_min, 2, "d", "rect_min"),
                                              _arrays.fixed(rect_max, 2, "d", "rect_max"),
                                              ctypes.byref(h)))
        return _from_medium(cls, h, medium)

    @classmethod
    def fiber(cls, medium, face, centre, radius, numerical_aperture):
        """A fiber probe: power leaving through a disk of `radius` centred at face
        coordinates `centre`, within `numerical_aperture` (n_out·sin θ ≤ NA)."""
        h = ctypes.c_void_p()
        check(lib.sensor_create_fiber(_medium(medium), face_id(face), _arrays.fixed(centre, 2, "d", "centre"),
                                      number(radius, "radius"), number(numerical_aperture, "numerical_aperture"),
                                      ctypes.byref(h)))
        return _from_medium(cls, h, medium)

    @property
    def pixel_count(self):
        return lib.sensor_pixel_count(self._ptr)

    @property
    def size(self):
        """(width, height); (1, 1) for a hemispherical detector or a fiber."""
        w, h = ctypes.c_int32(), ctypes.c_int32()
        check(lib.sensor_get_size(self._ptr, ctypes.byref(w), ctypes.byref(h)))
        return w.value, h.value


class Pathlength(Handle):
    """hetinv_pathlength_t: Pathlength.steady(ctx) or Pathlength.bins(ctx, ...)."""

    _destroy_name = "pathlength_destroy"

    @classmethod
    def _made(cls, h, ctx):
        p = cls._wrap(h, [ctx])
        p.context = ctx
        return p

    @classmethod
    def steady(cls, ctx):
        """Steady state: one bin, every pathlength."""
        h = ctypes.c_void_p()
        check(lib.pathlength_create_steady(_ctx(ctx), ctypes.byref(h)))
        return cls._made(h, ctx)

    @classmethod
    def bins(cls, ctx, centres, width, window="box"):
        """Pathlength bins at `centres` of width (box) or standard deviation
        (window="gaussian") `width`."""
        cp = _ctx(ctx)
        c = _arrays.to_c(centres, "d", name="centres")
        h = ctypes.c_void_p()
        check(lib.pathlength_create_bins(cp, lookup(window, WINDOWS, "window"),
                                         integer(c.count, "len(centres)"), c.ptr,
                                         number(width, "width"), ctypes.byref(h)))
        return cls._made(h, ctx)

    @classmethod
    def bins_irf(cls, ctx, centres, width, irf_offsets, irf_samples, window="box"):
        """Pathlength bins as `bins` makes them, seen through an instrument
        response function: samples `irf_samples` (≥ 0, normalised to sum 1)
        at pathlength offsets `irf_offsets` (the medium's length unit; see
        irf_offsets_from_times for a time axis in ps). A photon of
        pathlength τ is scored at τ + offset with the sample's weight."""
        cp = _ctx(ctx)
        c = _arrays.to_c(centres, "d", name="centres")
        o = _arrays.to_c(irf_offsets, "d", name="irf_offsets")
        h = _arrays.to_c(irf_samples, "d", o.count, "irf_samples")
        out = ctypes.c_void_p()
        check(lib.pathlength_create_bins_irf(cp, lookup(window, WINDOWS, "window"),
                                             integer(c.count, "len(centres)"), c.ptr,
                                             number(width, "width"),
                                             integer(o.count, "len(irf_offsets)"), o.ptr, h.ptr,
                                             ctypes.byref(out)))
        return cls._made(out, ctx)

    @property
    def bin_count(self):
        return lib.pathlength_bin_count(self._ptr)


def irf_offsets_from_times(times_ps, eta, length_unit_mm=1.0):
    """Times of flight in picoseconds as pathlengths in the medium,
    c₀·t/η in the medium's length unit (length_unit_mm: 1 for mm, 10 for
    cm). Returns a new array, flat like the input read in C order."""
    t = _arrays.to_c(times_ps, "d", name="times_ps")
    out, po = _arrays.empty(t.count)
    check(lib.irf_offsets_from_times(t.ptr, t.count, number(eta, "eta"),
                                     number(length_unit_mm, "length_unit_mm"), po))
    return out
