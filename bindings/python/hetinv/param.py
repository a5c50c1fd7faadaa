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

    `free` is a mask (hetinv.FREE_ALL, FREE_SIGMA_A | FREE_SIGMA_S, ...), a
    parameter name, or a list of names, e.g. ("sigma_a", "sigma_s"); an int
    inside a list is refused (a FREE_* mask or a PARAM_* id?).

    π is parameter-major: one block per free parameter (in the order σa, σs,
    g: self.params), each block the map's cells in linear order, x fastest.
    With numpy, every π the binding returns (extract, pullback, the
    estimator's gradients) has shape self.shape = (free parameters, cz, cy,
    cx), the map's own grid with dims (cx, cy, cz) reversed: the medium's
    grid for an identity map, coarse_dims for a coarse map, the grid with
    the broadcast axis of length 1 for a broadcast map. pi[k, iz, iy, ix] is
    cell (ix, iy, iz) of free parameter self.params[k]; pi.ravel() is the
    library's order, and split(pi) names the blocks. Without numpy π is a
    flat array.array. Inputs (apply's π, pullback's voxel gradient) may have
    any shape and are read in C order.
    """

    _destroy_name = "param_map_destroy"

    @classmethod
    def _made(cls, h, medium):
        m = cls._wrap(h, [medium.context])
        m.context = medium.context
        m._voxel_count = medium.voxel_count  # V of the grid: pullback reads 3·V values
        m._grid_shape = tuple(medium.shape)  # (nz, ny, nx): pullback's blocks
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

    @property
    def params(self):
        """Names of the free parameters, in π's block order, e.g. ("sigma_s",)."""
        mask = self.free_mask
        return tuple(n for n, bit in (("sigma_a", 1), ("sigma_s", 2), ("g", 4)) if mask & bit)

    @property
    def shape(self):
        """(free parameters, cz, cy, cx): the numpy shape of π."""
        cx, cy, cz = self.dims
        return len(self.params), cz, cy, cx

    def shaped(self, pi):
        """`pi` (any π of this map, e.g. Optimizer.get_pi()) as a numpy array
        of shape self.shape; without numpy, as it is."""
        return _arrays.shaped(pi, self.shape)

    def split(self, pi):
        """{parameter name: its block of `pi`}: with numpy, views of shape
        (cz, cy, cx); without, flat slices."""
        n = len(self.params)
        if _arrays.is_numpy(pi):
            blocks = pi.reshape(self.shape)
            return {p: blocks[k] for k, p in enumerate(self.params)}
        if len(pi) != self.size:
            raise ValueError("pi: expected %d values, got %d" % (self.size, len(pi)))
        cells = self.size // n
        return {p: pi[k * cells:(k + 1) * cells] for k, p in enumerate(self.params)}

    def entry(self, index):
        """(parameter id, cell) of π entry `index`."""
        p, c = ctypes.c_int32(), ctypes.c_size_t()
        check(lib.param_map_entry(self._ptr, integer(index, "index", "size_t"), ctypes.byref(p),
                                  ctypes.byref(c)))
        return p.value, c.value

    def apply(self, pi, medium):
        """Write π into an uncommitted medium."""
        mp = _medium(medium)
        a = _arrays.to_c(pi, "d", name="pi", shape=self.shape)
        check(lib.param_map_apply(self._ptr, a.ptr, a.count, mp))
        return medium

    def extract(self, medium):
        """π from a medium (cell averages for coarse and broadcast maps),
        shaped self.shape with numpy."""
        mp = _medium(medium)
        n = self.size
        out, ptr = _arrays.empty(n, "d", self.shape)
        check(lib.param_map_extract(self._ptr, mp, ptr, n))
        return out

    def pullback(self, voxel_grad):
        """∂/∂π (shaped self.shape with numpy) from 3·V voxel gradients (σa
        of every voxel, then σs, then g: e.g. an array of shape (3, nz, ny, nx))."""
        g = _arrays.to_c(voxel_grad, "d", 3 * self._voxel_count, "voxel_grad", shape=(3,) + self._grid_shape)
        n = self.size
        out, ptr = _arrays.empty(n, "d", self.shape)
        check(lib.param_map_pullback(self._ptr, g.ptr, ptr, n))
        return out

    def local_crb(self, fisher, radius=1):
        """The local Cramér–Rao bound from a Fisher matrix of this map's
        entries (Estimator.fisher().fisher, k·k values): each entry's bound
        with only the cells within `radius` of its own unknown; a lower
        bound of Estimator.crb()'s that grows with the radius (bound.h).
        Shaped self.shape with numpy; inf where nothing reaches the entry,
        nan where the window's matrix is not positive definite."""
        n = self.size
        f = _arrays.to_c(fisher, "d", n * n, "fisher")
        out, ptr = _arrays.empty(n, "d", self.shape)
        check(lib.fisher_local_crb(self._ptr, f.ptr, n, integer(radius, "radius", "int32"), ptr))
        return out

    def blocks_crb(self, blocks):
        """The local Cramér–Rao bound at radius 0 from the blocks of
        Estimator.fisher_blocks(): each entry's bound with only its own
        cell's parameters unknown, a lower bound of Estimator.crb()'s.
        Shaped self.shape with numpy; inf where nothing reaches the entry,
        nan where the cell's block is not positive definite."""
        n = self.size
        b = _arrays.to_c(blocks, "d", n * len(self.params), "blocks")
        out, ptr = _arrays.empty(n, "d", self.shape)
        check(lib.fisher_blocks_crb(self._ptr, b.ptr, n, ptr))
        return out
