"""numpy is optional: with it, arrays come back as numpy arrays and numpy
inputs of any shape are read in C order; without it (or switched off)
array.array. The numpy tests skip when numpy is not importable."""
import array
import unittest

import hetinv
import scene

try:
    import numpy as np
except ImportError:
    np = None


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

    def test_noise_and_vol_with_numpy(self):
        noisy = hetinv.apply_noise(self.ctx, np.full(5, 0.5), seed=1)
        self.assertIsInstance(noisy.values, np.ndarray)
        self.assertEqual(noisy.values.shape, (5,))


if __name__ == "__main__":
    unittest.main()
