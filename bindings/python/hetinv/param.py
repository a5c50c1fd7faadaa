"""Parameter maps: the vector π and how it spreads over a medium's voxels (param.h)."""
import ctypes

from . import _arrays
from ._args import integer
from ._errors import check
from ._handle import Handle, handle_arg
from ._lib import lib
from ._names import free_mask


def _medium(medium, name="medium"):
    from .medium import Medium

    return handle_arg(medium, Medium, name)


class ParamMap(Handle):
    """hetinv_param_map_t: ParamMap.identity / coarse / broadcast(medium, ..., free).

    `free` is a mask (hetinv.FREE_ALL, FREE_SIGMA_S, ...), a parameter name
    or a list of them, e.g. ("sigma_a", "sigma_s").
    """

    _destroy_name = "param_map_destroy"

    @classmethod
    def _made(cls, h, medium):
        m = cls._wrap(h, [medium.context])
        m.context = medium.context
        m._voxel_count = medium.voxel_count  # V of the grid: pullback reads 3·V values
        return m

    @classmethod
    def identity(cls, medium, free="sigma_s"):
        mp, mask = _medium(medium), integer(free_mask(free), "free", "uint32")
        h = ctypes.c_void_p()
        check(lib.param_map_create_identity(mp, mask, ctypes.byref(h)))
        return cls._made(h, medium)

    @classmethod
    def coarse(cls, medium, coarse_dims, free="sigma_s"):
        mp, mask = _medium(medium), integer(free_mask(free), "free", "uint32")
        dims = _arrays.fixed(coarse_dims, 3, "i", "coarse_dims")
        h = ctypes.c_void_p()
        check(lib.param_map_create_coarse(mp, dims, mask, ctypes.byref(h)))
        return cls._made(h, medium)

    @classmethod
    def broadcast(cls, medium, axis, free="sigma_s"):
        mp, mask = _medium(medium), integer(free_mask(free), "free", "uint32")
        h = ctypes.c_void_p()
        check(lib.param_map_create_broadcast(mp, integer(axis, "axis"), mask, ctypes.byref(h)))
        return cls._made(h, medium)

    @property
    def size(self):
        """K, the length of π."""
        return lib.param_map_size(self._ptr)

    def __len__(self):
        return self.size

    @property
    def free_mask(self):
        return lib.param_map_free_mask(self._ptr)

    @property
    def dims(self):
        d = (ctypes.c_int32 * 3)()
        check(lib.param_map_get_dims(self._ptr, d))
        return tuple(d)

    def entry(self, index):
        """(parameter id, cell) of π entry `index`."""
        p, c = ctypes.c_int32(), ctypes.c_size_t()
        check(lib.param_map_entry(self._ptr, integer(index, "index", "size_t"), ctypes.byref(p),
                                  ctypes.byref(c)))
        return p.value, c.value

    def apply(self, pi, medium):
        """Write π into an uncommitted medium."""
        mp = _medium(medium)
        a = _arrays.to_c(pi, "d", name="pi")
        check(lib.param_map_apply(self._ptr, a.ptr, a.count, mp))
        return medium

    def extract(self, medium):
        """π from a medium (cell averages for coarse and broadcast maps)."""
        mp = _medium(medium)
        n = self.size
        out, ptr = _arrays.empty(n)
        check(lib.param_map_extract(self._ptr, mp, ptr, n))
        return out

    def pullback(self, voxel_grad):
        """∂/∂π from 3·V voxel gradients (σa of every voxel, then σs, then g)."""
        g = _arrays.to_c(voxel_grad, "d", 3 * self._voxel_count, "voxel_grad")
        n = self.size
        out, ptr = _arrays.empty(n)
        check(lib.param_map_pullback(self._ptr, g.ptr, ptr, n))
        return out
