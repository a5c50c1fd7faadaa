"""The voxel medium and Mitsuba .vol files."""
import ctypes

from . import _arrays
from ._args import integer, number, path as _path
from ._errors import OutOfRangeError, check
from ._handle import Handle, handle_arg
from ._lib import lib
from ._names import PARAMS, lookup
from ._structs import MixtureSpec, SmokeSpec, VolHeader


def param_id(param):
    """HETINV_PARAM_* from 0/1/2 or "sigma_a"/"sigma_s"/"g"."""
    return lookup(param, PARAMS, "parameter")


def param_name(param):
    return lib.param_name(param_id(param)).decode()


class Medium(Handle):
    """hetinv_medium_t: a box of nx × ny × nz voxels holding σa, σs and g.

    Create, set values (each validated), commit(); a committed medium is
    immutable (clone() it to change it). Grids are in linear voxel order,
    x fastest: voxel (ix, iy, iz) is item ix + nx·(iy + ny·iz). With numpy,
    grid() returns an array of shape (nz, ny, nx) (self.shape), so
    grid[iz, iy, ix] is that voxel and grid.ravel() the linear order.
    """

    _destroy_name = "medium_destroy"

    def __init__(self, ctx, box_min, box_max, dims):
        from .context import Context

        c = handle_arg(ctx, Context, "ctx")
        lo = _arrays.fixed(box_min, 3, "d", "box_min")
        hi = _arrays.fixed(box_max, 3, "d", "box_max")
        n = _arrays.fixed(dims, 3, "i", "dims")
        h = ctypes.c_void_p()
        check(lib.medium_create(c, lo, hi, n, ctypes.byref(h)))
        super().__init__(h, [ctx])
        self.context = ctx

    @classmethod
    def _adopt_new(cls, handle, ctx):
        m = cls._wrap(handle, [ctx])
        m.context = ctx
        return m

    def clone(self):
        """An uncommitted copy (same context)."""
        h = ctypes.c_void_p()
        check(lib.medium_clone(self._ptr, ctypes.byref(h)))
        return Medium._adopt_new(h, self.context)

    def set_ior(self, eta, eta_out=1.0):
        check(lib.medium_set_ior(self._ptr, number(eta, "eta"), number(eta_out, "eta_out")))
        return self

    def fill(self, sigma_a, sigma_s, g):
        check(lib.medium_fill(self._ptr, number(sigma_a, "sigma_a"), number(sigma_s, "sigma_s"),
                              number(g, "g")))
        return self

    def set_voxel(self, ix, iy, iz, sigma_a, sigma_s, g):
        check(lib.medium_set_voxel(self._ptr, integer(ix, "ix"), integer(iy, "iy"),
                                   integer(iz, "iz"), number(sigma_a, "sigma_a"),
                                   number(sigma_s, "sigma_s"), number(g, "g")))

    def get_voxel(self, ix, iy, iz):
        """(σa, σs, g) of voxel (ix, iy, iz)."""
        a, s, g = ctypes.c_double(), ctypes.c_double(), ctypes.c_double()
        check(lib.medium_get_voxel(self._ptr, integer(ix, "ix"), integer(iy, "iy"),
                                   integer(iz, "iz"), ctypes.byref(a), ctypes.byref(s),
                                   ctypes.byref(g)))
        return a.value, s.value, g.value

    def set_grid(self, param, values):
        """Set one parameter of every voxel (voxel_count values, x fastest:
        flat, or a numpy array of shape self.shape = (nz, ny, nx); another
        shape of the same size is refused, not read transposed)."""
        arr = _arrays.to_c(values, "d", name="values", shape=self.shape)
        check(lib.medium_set_grid(self._ptr, param_id(param), arr.ptr, arr.count))
        return self

    def grid(self, param):
        """A copy of one parameter of every voxel: with numpy an array of
        shape (nz, ny, nx), indexed [iz, iy, ix]; else a flat array.array in
        linear voxel order (x fastest). A copy, because the medium owns the
        values (and a medium that is not committed may still change them)."""
        ptr = lib.medium_grid(self._ptr, param_id(param))
        if not ptr:  # the library returns NULL without a message for an unknown param
            raise OutOfRangeError("hetinv_medium_grid: unknown parameter %r" % (param,))
        return _arrays.copy_from(ptr, self.voxel_count, "d", self.shape)

    def commit(self):
        check(lib.medium_commit(self._ptr))
        return self

    @property
    def committed(self):
        return bool(lib.medium_is_committed(self._ptr))

    @property
    def dims(self):
        d = (ctypes.c_int32 * 3)()
        check(lib.medium_get_dims(self._ptr, d))
        return tuple(d)

    @property
    def shape(self):
        """(nz, ny, nx): the numpy shape of a grid (dims reversed)."""
        nx, ny, nz = self.dims
        return nz, ny, nx

    @property
    def voxel_count(self):
        return lib.medium_voxel_count(self._ptr)

    @property
    def box(self):
        """((xmin, ymin, zmin), (xmax, ymax, zmax))."""
        lo, hi = (ctypes.c_double * 3)(), (ctypes.c_double * 3)()
        check(lib.medium_get_box(self._ptr, lo, hi))
        return tuple(lo), tuple(hi)

    @property
    def ior(self):
        """(η inside, η outside)."""
        eta, out = ctypes.c_double(), ctypes.c_double()
        check(lib.medium_get_ior(self._ptr, ctypes.byref(eta), ctypes.byref(out)))
        return eta.value, out.value

    def read_vol(self, param, path):
        """Set one parameter from a 1-channel .vol file of the same grid."""
        check(lib.medium_read_vol(self._ptr, param_id(param), _path(path)))
        return self

    def write_vol(self, param, path):
        """Write one parameter as a 1-channel .vol file (float32, atomic)."""
        check(lib.medium_write_vol(self._ptr, param_id(param), _path(path)))

    # simulated volumes (acquire.h)
    def fill_gaussian_mixture(self, spec=None, **fields):
        """σa, σs, g from a random Gaussian mixture (hetinv_volume_gaussian_mixture).
        spec: a MixtureSpec, or its fields as keywords over the defaults."""
        spec = _spec(spec, fields, MixtureSpec)
        check(lib.volume_gaussian_mixture(self._ptr, ctypes.byref(spec)))
        return self

    def fill_smoke(self, spec=None, **fields):
        """σa, σs, g from a smoke plume (hetinv_volume_smoke)."""
        spec = _spec(spec, fields, SmokeSpec)
        check(lib.volume_smoke(self._ptr, ctypes.byref(spec)))
        return self


def _spec(spec, fields, cls, name="spec"):
    """`spec` if it is a `cls` (the library reads it as one), else `cls(**fields)`."""
    if spec is None:
        return cls(**fields)
    if not isinstance(spec, cls):
        raise TypeError("%s: expected hetinv.%s, got %s"
                        % (name, cls.__name__, type(spec).__name__))
    if fields:
        raise TypeError("give either spec or its fields as keywords, not both")
    return spec


def _ctx(ctx):
    from .context import Context

    return handle_arg(ctx, Context, "ctx")


def vol_read_header(ctx, path):
    """The VolHeader of a .vol file (validated; values not read)."""
    header = VolHeader()
    check(lib.vol_read_header(_ctx(ctx), _path(path), ctypes.byref(header)))
    return header


def vol_read(ctx, path):
    """(VolHeader, float32 values in file order: ((z·ny + y)·nx + x)·channels + c).
    With numpy the values have shape (nz, ny, nx, channels); else they are a
    flat array.array('f')."""
    header = vol_read_header(ctx, path)
    nx, ny, nz = header.dims
    n = nx * ny * nz * header.channels
    data, ptr = _arrays.empty(n, "f", (nz, ny, nx, header.channels))
    check(lib.vol_read(_ctx(ctx), _path(path), ctypes.byref(header), ptr, n))
    return header, data


def vol_write(ctx, path, data, dims, box_min=(0.0, 0.0, 0.0), box_max=(1.0, 1.0, 1.0),
              channels=1):
    """Write float values (rounded to float32) as a .vol file (atomic).
    dims = (nx, ny, nz), x fastest: flat data, or a numpy array of shape
    (nz, ny, nx) (with a last axis of `channels` if more than one)."""
    c = _ctx(ctx)
    header = VolHeader()
    header.dims[:] = list(_arrays.fixed(dims, 3, "i", "dims"))
    header.channels = integer(channels, "channels")
    header.box_min[:] = list(_arrays.fixed(box_min, 3, "d", "box_min"))
    header.box_max[:] = list(_arrays.fixed(box_max, 3, "d", "box_max"))
    nx, ny, nz = header.dims
    shape = (nz, ny, nx) + ((header.channels,) if header.channels > 1 else ())
    arr = _arrays.to_c(data, "f", name="data", shape=shape)
    check(lib.vol_write(c, _path(path), ctypes.byref(header), arr.ptr, arr.count))
