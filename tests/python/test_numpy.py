"""numpy is optional: with it, arrays come back as numpy arrays shaped like
the grid they belong to, numpy inputs are read in C order (in the shape the
binding expects where it knows one, else refused), and
float64 C-contiguous arrays cross into C without a copy; without it (or
switched off) flat array.array. The numpy tests skip when numpy is not
importable."""
import array
import contextlib
import ctypes
import os
import tempfile
import unittest

import hetinv
import scene

try:
    import numpy as np
except ImportError:
    np = None


@contextlib.contextmanager
def spy(name, record):
    """Record the data addresses of the pointer arguments of the C function
    `name` (hetinv._lib.lib.<name>) while the block runs."""
    lib = hetinv._lib.lib
    real = getattr(lib, name)

    def wrapper(*args):
        record.append([ctypes.cast(a, ctypes.c_void_p).value if isinstance(a, ctypes._Pointer)
                       else None for a in args])
        return real(*args)

    setattr(lib, name, wrapper)
    try:
        yield record
    finally:
        setattr(lib, name, real)


def grid_medium(ctx):
    """nx, ny, nz = 4, 3, 2: no two axes alike, so a transposed shape shows."""
    m = hetinv.Medium(ctx, (0, 0, 0), (4, 3, 2), (4, 3, 2)).fill(0.1, 5.0, 0.5)
    m.set_voxel(3, 1, 0, 0.2, 9.0, 0.5)
    m.set_voxel(0, 2, 1, 0.3, 7.0, 0.25)
    return m.commit()


def render(ctx):
    truth = scene.truth_medium(ctx)
    ms = scene.measurement_set(ctx, truth)
    return truth, ms, hetinv.Estimator(ctx, photons=300).render(truth, ms)


class WithoutNumpy(unittest.TestCase):
    def test_outputs_are_array_array_and_inputs_any_sequence(self):
        previous = hetinv.use_numpy(False) if hetinv.numpy_available() else False
        try:
            self.assertFalse(hetinv.numpy_enabled())
            with hetinv.Context(seed=2, threads=1) as ctx:
                truth, ms, r = render(ctx)
                self.assertIsInstance(r.values, array.array)
                self.assertEqual(r.values.typecode, "d")
                ms.set_values(tuple(r.values))          # a tuple
                ms.set_values(list(r.values))           # a list
                ms.set_values(r.values)                 # an array.array
                self.assertEqual(scene.bits(ms.values), scene.bits(r.values))
                self.assertIsInstance(ms.mask, array.array)
                self.assertEqual(ms.mask.typecode, "B")
                # Without numpy every output is flat, in the library's linear order.
                g = grid_medium(ctx).grid("sigma_s")
                self.assertIsInstance(g, array.array)
                self.assertEqual((len(g), g[3 + 4 * 1], g[0 + 4 * (2 + 3 * 1)]), (24, 9.0, 7.0))
                self.assertIs(hetinv.flat(g), g)
                self.assertEqual(list(r.row(6)), list(r.values[15:27]))  # a flat slice
                self.assertEqual(list(ms.row(r.values, 1)), [r.values[4]])
                pmap = hetinv.ParamMap.identity(truth, ("sigma_a", "sigma_s"))
                pi = pmap.extract(truth)
                self.assertEqual(len(pi), 32)
                blocks = pmap.split(pi)
                self.assertEqual(list(blocks), ["sigma_a", "sigma_s"])
                self.assertEqual(blocks["sigma_s"][1 + 4 * 1], 8.0)
                grad = hetinv.Estimator(ctx, photons=300).gradient(truth, ms, [1.0] * 27, pmap)
                self.assertIsInstance(grad.grad, array.array)
                self.assertEqual(len(grad.grad), 32)
        finally:
            if previous:
                hetinv.use_numpy(True)

    def test_use_numpy_without_numpy_is_an_import_error(self):
        if hetinv.numpy_available():
            self.skipTest("numpy is importable")
        with self.assertRaises(ImportError):
            hetinv.use_numpy(True)


@unittest.skipIf(np is None, "numpy is not importable")
class WithNumpy(unittest.TestCase):
    def setUp(self):
        hetinv.use_numpy(True)
        self.ctx = hetinv.Context(seed=2, threads=1)

    def tearDown(self):
        self.ctx.close()

    def test_outputs_are_numpy_arrays(self):
        truth, ms, r = render(self.ctx)
        self.assertIsInstance(r.values, np.ndarray)
        self.assertEqual(r.values.dtype, np.float64)
        self.assertEqual(r.values.shape, (27,))
        self.assertEqual(truth.grid("sigma_s").reshape(4, 4)[1, 1], 8.0)

    def test_numpy_inputs_equal_list_inputs(self):
        truth, ms, r = render(self.ctx)
        ms.set_values(r.values)
        a = ms.values.copy()
        ms.set_values(r.values.tolist())
        self.assertEqual(a.tobytes(), ms.values.tobytes())
        ms.set_mask(np.arange(27) % 2 == 0)
        self.assertEqual(ms.mask.tolist(), [1 - i % 2 for i in range(27)])

    def test_shaped_and_strided_inputs_are_read_in_c_order(self):
        m = hetinv.Medium(self.ctx, (0, 0, 0), (4, 4, 1), (4, 4, 1))
        grid = np.arange(16, dtype=np.float32).reshape(1, 4, 4)  # (nz, ny, nx), float32
        m.set_grid("sigma_s", grid)
        self.assertEqual(m.get_voxel(3, 2, 0)[1], 11.0)
        m.set_grid("sigma_a", np.linspace(0, 1, 32)[::2])       # strided
        self.assertEqual(m.grid("sigma_a")[0, 0, 1], np.linspace(0, 1, 32)[2])

    def test_complex_and_out_of_float32_values_are_refused(self):
        # numpy only warned: complex values lost their imaginary part, and a
        # float64 past float32's range became inf.
        m = hetinv.Medium(self.ctx, (0, 0, 0), (4, 4, 1), (4, 4, 1))
        with self.assertRaisesRegex(TypeError, "values: complex values"):
            m.set_grid("sigma_s", np.ones(16, dtype=complex))
        with self.assertRaisesRegex(ValueError, r"data: 1e\+300 is beyond float32's range"):
            hetinv.vol_write(self.ctx, "unused.vol", np.array([1e300, 1.0, 1.0, 1.0]), (2, 2, 1))

    def test_noise_and_vol_with_numpy(self):
        noisy = hetinv.apply_noise(self.ctx, np.full(5, 0.5), seed=1)
        self.assertIsInstance(noisy.values, np.ndarray)
        self.assertEqual(noisy.values.shape, (5,))
        shaped = hetinv.apply_noise(self.ctx, np.full((1, 5), 0.5), seed=1)
        self.assertEqual((shaped.values.shape, shaped.std_errors.shape), ((1, 5), (1, 5)))
        self.assertEqual(shaped.values.tobytes(), noisy.values.tobytes())
        m = grid_medium(self.ctx)
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "sigma_s.vol")
            m.write_vol("sigma_s", path)
            header, data = hetinv.vol_read(self.ctx, path)
        self.assertEqual((data.shape, data.dtype), ((2, 3, 4, 1), np.float32))
        self.assertEqual(data[:, :, :, 0].tolist(), m.grid("sigma_s").tolist())


@unittest.skipIf(np is None, "numpy is not importable")
class Shapes(unittest.TestCase):
    """Per-voxel and per-cell outputs have the grid's shape, C order: the
    library's linear index ix + nx·(iy + ny·iz) is [iz, iy, ix]."""

    def setUp(self):
        hetinv.use_numpy(True)
        self.ctx = hetinv.Context(seed=2, threads=1)

    def tearDown(self):
        self.ctx.close()

    def test_grid_is_nz_ny_nx(self):
        m = grid_medium(self.ctx)
        self.assertEqual((m.dims, m.shape), ((4, 3, 2), (2, 3, 4)))
        g = m.grid("sigma_s")
        self.assertEqual((g.shape, g.dtype), ((2, 3, 4), np.float64))
        self.assertEqual((g[0, 1, 3], g[1, 2, 0]), (9.0, 7.0))
        self.assertEqual(g.ravel()[3 + 4 * (1 + 3 * 0)], 9.0)
        for iz in range(2):
            for iy in range(3):
                for ix in range(4):
                    self.assertEqual(m.grid("sigma_a")[iz, iy, ix], m.get_voxel(ix, iy, iz)[0])
        c = m.clone()
        c.set_grid("g", g / 10.0)        # a grid goes back in as it came out
        self.assertEqual(c.get_voxel(3, 1, 0)[2], 0.9)
        self.assertEqual(hetinv.flat(g).shape, (24,))

    def test_pi_and_gradients_have_the_maps_shape(self):
        m = grid_medium(self.ctx)
        maps = {"identity": (hetinv.ParamMap.identity(m, hetinv.FREE_ALL), (3, 2, 3, 4)),
                "identity_s": (hetinv.ParamMap.identity(m, "sigma_s"), (1, 2, 3, 4)),
                "coarse": (hetinv.ParamMap.coarse(m, (2, 3, 1), ("sigma_a", "g")), (2, 1, 3, 2)),
                "broadcast": (hetinv.ParamMap.broadcast(m, 1, "sigma_s"), (1, 2, 1, 4))}
        for name, (pmap, shape) in maps.items():
            with self.subTest(name):
                self.assertEqual(pmap.shape, shape)
                self.assertEqual(pmap.extract(m).shape, shape)
                self.assertEqual(pmap.pullback(np.ones((3, 2, 3, 4))).shape, shape)
        ident = maps["identity"][0]
        self.assertEqual(ident.params, ("sigma_a", "sigma_s", "g"))
        pi = ident.extract(m)
        self.assertEqual((pi[1, 0, 1, 3], pi[2, 1, 2, 0]), (9.0, 0.25))  # [param, iz, iy, ix]
        for k, p in enumerate(ident.params):
            self.assertEqual(pi[k].tolist(), m.grid(p).tolist())
            self.assertTrue(np.shares_memory(ident.split(pi)[p], pi))
        # A voxel gradient in (3, nz, ny, nx) goes through the identity unchanged.
        voxel = np.arange(72, dtype=np.float64).reshape(3, 2, 3, 4)
        self.assertEqual(ident.pullback(voxel).tolist(), voxel.tolist())
        # The broadcast map's cell (ix, 0, iz) holds the mean along y.
        flat_y = maps["broadcast"][0].extract(m)
        self.assertEqual(flat_y[0, 0, 0, 3], (9.0 + 5.0 + 5.0) / 3)
        # The estimator's gradients come in the same shape.
        ms = hetinv.Measurements(self.ctx)
        ms.add(hetinv.Emitter.ideal(m, (2, 1.5, 2.5), (0, 0, -1)),
               hetinv.Sensor.hemispherical(m, "z_max"))
        est = hetinv.Estimator(self.ctx, photons=200)
        for name, (pmap, shape) in maps.items():
            with self.subTest(name):
                g = est.gradient(m, ms, [1.0], pmap)
                self.assertEqual((g.grad.shape, g.std_errors.shape), (shape, shape))
                ms.set_values([0.1])
                lg = est.loss_gradient(m, ms, pmap)
                self.assertEqual((lg.grad.shape, lg.rendered.shape), (shape, (1,)))
        self.assertEqual(ident.shaped(np.zeros(72)).shape, (3, 2, 3, 4))

    def test_render_rows_are_bins_height_width(self):
        # A pencil beam enters the top face in pixel (i, j) = (2, 0) of a
        # 3 × 2 camera on that face: that pixel is the brightest of its row.
        m = hetinv.Medium(self.ctx, (0, 0, 0), (3, 2, 1), (1, 1, 1)).fill(0.05, 5.0, 0.0)
        m.set_ior(1.0, 1.0).commit()
        cam = hetinv.Sensor.orthographic(m, "z_max", (0, 0, 1), (0, 0), (1, 1), 3, 2)
        ms = hetinv.Measurements(self.ctx)
        beam = hetinv.Emitter.ideal(m, (2.5, 0.5, 1.5), (0, 0, -1))
        ms.add(beam, hetinv.Sensor.hemispherical(m, "z_min"))
        ms.add(beam, cam)
        ms.add(beam, cam, hetinv.Pathlength.bins(self.ctx, [1, 3, 5, 7], 2))
        self.assertEqual([ms.row_shape(r) for r in range(3)], [(1, 1, 1), (1, 2, 3), (4, 2, 3)])
        r = hetinv.Estimator(self.ctx, photons=4000).render(m, ms)
        self.assertEqual(r.values.shape, (31,))  # flat: rows differ in shape
        image = r.row(1)
        self.assertEqual(image.shape, (1, 2, 3))
        self.assertEqual(np.unravel_index(np.argmax(image), image.shape), (0, 0, 2))
        self.assertTrue(np.shares_memory(image, r.values))
        self.assertEqual(image.ravel().tolist(), r.values[1:7].tolist())
        bins = r.row(2, "std_errors")
        self.assertEqual(bins.shape, (4, 2, 3))
        # offset + b·pixels + p, p = j·width + i
        self.assertEqual(bins[3, 1, 0], r.std_errors[7 + 3 * 6 + 1 * 3 + 0])
        self.assertEqual(ms.row(r.values, 2).tolist(), r.row(2).tolist())
        with self.assertRaises(ValueError):
            r.row(0, "nope")
        for bad in (3, -1):
            with self.assertRaises(IndexError):
                r.row(bad)
            with self.assertRaises(IndexError):  # OutOfRangeError is an IndexError
                ms.row(r.values, bad)
        with self.assertRaises(ValueError):
            ms.row(r.values[:30], 0)


@unittest.skipIf(np is None, "numpy is not importable")
class ZeroCopy(unittest.TestCase):
    """float64 C-contiguous inputs reach C as they are, and C writes outputs
    straight into the arrays returned (the pointers are the arrays' data)."""

    def setUp(self):
        hetinv.use_numpy(True)
        self.ctx = hetinv.Context(seed=2, threads=1)

    def tearDown(self):
        self.ctx.close()

    def test_inputs_are_not_copied(self):
        m = hetinv.Medium(self.ctx, (0, 0, 0), (4, 3, 2), (4, 3, 2))
        grid = np.linspace(1.0, 2.0, 24).reshape(2, 3, 4)
        with spy("medium_set_grid", []) as calls:
            m.set_grid("sigma_s", grid)
        self.assertEqual(calls[0][2], grid.ctypes.data)
        readonly = np.frombuffer(np.full(24, 3.0).tobytes(), dtype=np.float64)
        self.assertFalse(readonly.flags.writeable)
        with spy("medium_set_grid", []) as calls:
            m.set_grid("sigma_s", readonly)   # the library only reads it
        self.assertEqual(calls[0][2], readonly.ctypes.data)
        # Another dtype or a strided view is converted (once), and still read in C order.
        for other in (grid.astype(np.float32), np.linspace(1.0, 2.0, 48)[::2], np.asfortranarray(grid)):
            with spy("medium_set_grid", []) as calls:
                m.set_grid("sigma_a", other)
            self.assertNotEqual(calls[0][2], other.ctypes.data)
            self.assertEqual(m.grid("sigma_a").ravel().tolist(),
                             np.ascontiguousarray(other, dtype=np.float64).ravel().tolist())
        m.fill(0.1, 5.0, 0.5).commit()
        pmap = hetinv.ParamMap.identity(m, "sigma_s")
        pi = pmap.extract(m)
        c = m.clone()
        with spy("param_map_apply", []) as calls:
            pmap.apply(pi, c)
        self.assertEqual(calls[0][1], pi.ctypes.data)
        ms = hetinv.Measurements(self.ctx)
        ms.add(hetinv.Emitter.ideal(m, (2, 1.5, 2.5), (0, 0, -1)),
               hetinv.Sensor.orthographic(m, "z_max", (0, 0, 1), (0, 0), (1, 1), 4, 3))
        cotangent = np.ones((1, 3, 4))
        with spy("estimator_gradient", []) as calls:
            hetinv.Estimator(self.ctx, photons=100).gradient(m, ms, cotangent, pmap)
        self.assertEqual(calls[0][3], cotangent.ctypes.data)
        values = np.full(12, 0.5)
        with spy("measurements_set_values", []) as calls:
            ms.set_values(values, values)
        self.assertEqual(calls[0][1:3], [values.ctypes.data] * 2)

    def test_outputs_are_written_in_place(self):
        m = grid_medium(self.ctx)
        ms = hetinv.Measurements(self.ctx)
        ms.add(hetinv.Emitter.ideal(m, (2, 1.5, 2.5), (0, 0, -1)),
               hetinv.Sensor.hemispherical(m, "z_max"))
        est = hetinv.Estimator(self.ctx, photons=100)
        with spy("estimator_render", []) as calls:
            r = est.render(m, ms)
        self.assertEqual(calls[0][3:6], [r.values.ctypes.data, r.std_errors.ctypes.data,
                                         r.ballistic.ctypes.data])
        pmap = hetinv.ParamMap.identity(m, hetinv.FREE_ALL)
        with spy("estimator_gradient", []) as calls:
            g = est.gradient(m, ms, [1.0], pmap)
        self.assertEqual(calls[0][6:8], [g.grad.ctypes.data, g.std_errors.ctypes.data])
        self.assertEqual(g.grad.shape, (3, 2, 3, 4))
        with spy("param_map_extract", []) as calls:
            pi = pmap.extract(m)
        self.assertEqual(calls[0][2], pi.ctypes.data)
        for a in (r.values, g.grad, pi):
            self.assertTrue(a.flags.c_contiguous and a.flags.writeable)


@unittest.skipIf(np is None, "numpy is not importable")
class Refusals(unittest.TestCase):
    """Inputs a numpy user writes naturally that the binding would misread
    are refused, naming what is wrong."""

    def setUp(self):
        self.ctx = hetinv.Context(seed=1, threads=1)
        self.m = hetinv.Medium(self.ctx, (0, 0, 0), (4, 3, 2), (4, 3, 2))  # shape (2, 3, 4)

    def tearDown(self):
        self.ctx.close()

    def test_a_grid_of_another_shape_is_refused_not_transposed(self):
        grid = np.arange(24.0).reshape(2, 3, 4) + 1.0
        with self.assertRaisesRegex(ValueError, r"values: an array of shape \(4, 3, 2\) where \(2, 3, 4\)"):
            self.m.set_grid("sigma_s", grid.T.copy())  # (nx, ny, nz), as meshgrid(indexing="ij") gives
        self.m.set_grid("sigma_s", grid[np.newaxis])  # a singleton axis is fine
        self.m.set_grid("sigma_s", grid.ravel())      # and so is flat
        with tempfile.TemporaryDirectory() as d:
            with self.assertRaisesRegex(ValueError, r"data: an array of shape \(4, 3, 2\)"):
                hetinv.vol_write(self.ctx, os.path.join(d, "t.vol"), grid.T.copy(), (4, 3, 2))
        img = hetinv.Image(self.ctx, 3, 2, 1)
        with self.assertRaisesRegex(ValueError, r"values: an array of shape \(3, 2\) where \(2, 3\)"):
            img.set_channel(0, np.zeros((3, 2)))
        self.m.fill(0.1, 2.0, 0.5).commit()
        pmap = hetinv.ParamMap.identity(self.m, hetinv.FREE_ALL)
        with self.assertRaisesRegex(ValueError, r"voxel_grad: an array of shape \(2, 3, 4, 3\)"):
            pmap.pullback(np.zeros((2, 3, 4, 3)))  # the parameter axis last

    def test_masked_and_string_arrays_are_refused(self):
        grid = np.ma.masked_equal(np.ones(24), 0.0)
        with self.assertRaisesRegex(TypeError, "values: a masked array"):
            self.m.set_grid("sigma_s", grid)
        with self.assertRaisesRegex(TypeError, "values of dtype <U"):
            self.m.set_grid("sigma_s", np.array(["1.5"] * 24))
        ms = hetinv.Measurements(self.ctx)
        ms.add(hetinv.Emitter.ideal(self.m, (2, 1.5, 2), (0, 0, -1)), hetinv.Sensor.hemispherical(self.m, "z_max"))
        with self.assertRaisesRegex(TypeError, "mask: a masked array"):
            ms.set_mask(np.ma.masked_array([0], mask=[True]))
        with self.assertRaisesRegex(TypeError, "mask: '0'; expected numbers or booleans"):
            ms.set_mask(["0"])

    def test_float32_range_is_checked_in_every_container(self):
        img = hetinv.Image(self.ctx, 2, 1, 1)
        for values in ([1e300, 1.0], array.array("d", [1e300, 1.0]), np.array([1e300, 1.0], dtype=object)):
            with self.assertRaisesRegex(ValueError, "values: 1e\\+300 is beyond float32's range"):
                img.set_channel(0, values)

    def test_scalars_as_numpy_gives_them(self):
        img = hetinv.Image(self.ctx, 2, 1, 2)
        with self.assertRaisesRegex(TypeError, "expected an integer, got bool True"):
            img[True]
        img.set_attribute("frames", np.int64(3))  # an int, not a double
        self.assertEqual(img.attributes["frames"], 3)
        self.assertIsInstance(img.attributes["frames"], int)
        with self.assertRaises(OverflowError):
            img.set_attribute("big", np.int64(2**40))
        self.m.fill(np.array(0.1), np.float64(2.0)[()], np.array([0.5]).mean(keepdims=True)[0])
        self.assertEqual(self.m.get_voxel(0, 0, 0), (0.1, 2.0, 0.5))

    def test_a_scalar_or_nested_list_names_the_parameter(self):
        for values in (3.0, [[1.0] * 12, [2.0] * 12]):
            with self.assertRaisesRegex(TypeError, "values: expected a flat sequence of numbers"):
                self.m.set_grid("sigma_a", values)

    def test_handles_say_they_cannot_be_pickled(self):
        import copy
        import pickle
        for f in (copy.deepcopy, pickle.dumps):
            with self.assertRaisesRegex(TypeError, "hetinv.Medium holds a C object and cannot be pickled or deep-copied; use clone"):
                f(self.m)
        self.assertIs(copy.copy(self.m), self.m)

    def test_ints_inside_a_free_list_are_refused(self):
        for free in ([hetinv.FREE_SIGMA_S], [hetinv.FREE_SIGMA_A, hetinv.FREE_SIGMA_S]):
            with self.assertRaisesRegex(TypeError, "inside a list; give parameter names there"):
                hetinv.ParamMap.identity(self.m, free)
        both = hetinv.ParamMap.identity(self.m, ["sigma_a", "sigma_s"])
        self.assertEqual(both.free_mask, hetinv.FREE_SIGMA_A | hetinv.FREE_SIGMA_S)


if __name__ == "__main__":
    unittest.main()
