"""Simulated acquisition through Python: the noise model's defaults come
from the C default function, noise and volumes are deterministic under
their seeds, and bad fields raise with the library's message."""
import unittest

import hetinv
import scene


class Noise(unittest.TestCase):
    def setUp(self):
        self.ctx = hetinv.Context(seed=1, threads=2)

    def tearDown(self):
        self.ctx.close()

    def test_defaults_come_from_the_library(self):
        m = hetinv.NoiseModel()
        self.assertEqual((m.full_well, m.read_noise, m.exposure, m.auto_level, m.seed),
                         (20000.0, 5.0, 0.0, 0.9, 0))
        self.assertEqual(m.size, 56)
        s = hetinv.MixtureSpec()
        self.assertEqual((list(s.lo), list(s.hi), s.components, s.constant_axis),
                         ([0.05, 1.0, 0.0], [0.5, 10.0, 0.9], 2, -1))
        k = hetinv.SmokeSpec(octaves=4)
        self.assertEqual((k.octaves, k.feature_size), (4, 0.25))
        with self.assertRaisesRegex(AttributeError, "no field 'octave'"):
            hetinv.SmokeSpec(octave=4)

    def test_noise_is_deterministic_and_automatic_exposure_reaches_the_level(self):
        clean = [0.0, 0.25, 0.5, 1.0]
        a = hetinv.apply_noise(self.ctx, clean, seed=9)
        b = hetinv.apply_noise(self.ctx, clean, hetinv.NoiseModel(seed=9))
        c = hetinv.apply_noise(self.ctx, clean, seed=10)
        self.assertEqual(scene.bits(a.values), scene.bits(b.values))
        self.assertNotEqual(scene.bits(a.values), scene.bits(c.values))
        self.assertEqual(a.exposure, 0.9 * 20000 / 1.0)
        self.assertTrue(all(e > 0 for e in a.std_errors))
        fixed = hetinv.apply_noise(self.ctx, clean, exposure=100.0, read_noise=0.0)
        self.assertEqual(fixed.exposure, 100.0)
        self.assertTrue(all((v * 100.0).is_integer() for v in fixed.values))

    def test_bad_model_and_values_raise_with_the_library_message(self):
        with self.assertRaisesRegex(hetinv.InvalidArgumentError, "read_noise"):
            hetinv.apply_noise(self.ctx, [1.0], read_noise=-1.0)
        with self.assertRaisesRegex(hetinv.InvalidArgumentError, "-2"):
            hetinv.apply_noise(self.ctx, [1.0, -2.0])
        with self.assertRaisesRegex(hetinv.InvalidArgumentError, "hetinv_noise_apply"):
            hetinv.apply_noise(self.ctx, [])


class Volumes(unittest.TestCase):
    def setUp(self):
        self.ctx = hetinv.Context(seed=1, threads=2)

    def tearDown(self):
        self.ctx.close()

    def medium(self):
        return hetinv.Medium(self.ctx, (0, 0, 0), (8, 8, 2), (8, 8, 2))

    def test_mixture_spans_its_range_and_is_deterministic(self):
        a = self.medium().fill_gaussian_mixture(seed=5, constant_axis=2)
        b = self.medium().fill_gaussian_mixture(hetinv.MixtureSpec(seed=5, constant_axis=2))
        for p in ("sigma_a", "sigma_s", "g"):
            self.assertEqual(scene.bits(a.grid(p)), scene.bits(b.grid(p)))
        s = hetinv.flat(a.grid("sigma_s"))  # linear order, x fastest
        self.assertEqual((min(s), max(s)), (1.0, 10.0))
        self.assertEqual(list(s[:64]), list(s[64:]))  # constant along z

    def test_smoke_lies_in_its_range(self):
        m = self.medium().fill_smoke(seed=2, lo=(0.0, 0.5, 0.3), hi=(0.1, 4.0, 0.6))
        s = hetinv.flat(m.grid("sigma_s"))
        self.assertEqual(max(s), 4.0)
        self.assertGreaterEqual(min(s), 0.5)

    def test_bad_specs_and_committed_media_raise(self):
        with self.assertRaisesRegex(hetinv.InvalidArgumentError, "components"):
            self.medium().fill_gaussian_mixture(components=99)
        with self.assertRaisesRegex(hetinv.InvalidArgumentError, "octaves"):
            self.medium().fill_smoke(octaves=0)
        with self.assertRaises(hetinv.InvalidStateError):
            self.medium().commit().fill_smoke()


if __name__ == "__main__":
    unittest.main()
