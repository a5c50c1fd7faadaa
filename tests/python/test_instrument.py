"""What real instruments need, through the binding: the calibration gain of
the loss (Estimator.gain_mode, gains()), pathlength bins seen through an
instrument response (Pathlength.bins_irf, irf_offsets_from_times) and the
saturation mask (Measurements.mask_saturated). The C tests (estimator_gain,
sampling_irf, sampling_mask) check the numbers; these check the binding's calls."""
import unittest

import hetinv
import scene


def problem(ctx):
    truth = scene.truth_medium(ctx)
    ms = scene.measurement_set(ctx, truth)
    return truth, ms, hetinv.ParamMap.identity(truth, "sigma_s")


class Gain(unittest.TestCase):
    def test_global_gain_recovers_a_known_scale(self):
        with hetinv.Context(seed=4, threads=1) as ctx:
            truth, ms, pm = problem(ctx)
            est = hetinv.Estimator(ctx, photons=300)
            self.assertEqual(est.gain_mode, "none")
            r = est.render(truth, ms)
            rendered, se = hetinv.flat(r.values), hetinv.flat(r.std_errors)
            ms.set_values([3.0 * v for v in rendered])
            est.gain_mode = "global"
            self.assertEqual(est.gain_mode, "global")
            lg = est.loss_gradient(truth, ms, pm)
            gains = list(hetinv.flat(est.gains()))
            self.assertEqual(len(gains), 1)
            # The least-squares gain against the expected render: the
            # denominator is I^2 less the render's variance (estimator.h).
            num = sum(v * 3.0 * v for v in rendered)
            den = sum(v * v - s * s for v, s in zip(rendered, se))
            self.assertAlmostEqual(gains[0] / (num / den), 1.0, places=12)
            self.assertGreater(gains[0], 3.0)
            loss = sum((gains[0] * v - 3.0 * v) ** 2 for v in rendered)
            self.assertAlmostEqual(lg.loss / loss, 1.0, places=10)
            est.gain_mode = hetinv.GAIN_PER_EMITTER
            est.loss_gradient(truth, ms, pm)
            self.assertEqual(len(hetinv.flat(est.gains())), 3)  # the scene's three emitters
            with self.assertRaises(hetinv.OutOfRangeError):
                est.gain_mode = 5
            with self.assertRaises(ValueError):
                est.gain_mode = "per_pixel"
            est.gain_mode = "none"
            with self.assertRaises(hetinv.InvalidStateError):
                est.gains()


class Irf(unittest.TestCase):
    def test_delta_irf_renders_the_bare_bins(self):
        with hetinv.Context(seed=4, threads=1) as ctx:
            truth = scene.truth_medium(ctx)
            beam = hetinv.Emitter.ideal(truth, (1, 4.5, 0.5), (0, -1, 0))
            cam = hetinv.Sensor.orthographic(truth, "y_max", (0, 1, 0), (0, 0), (1, 1), 4, 1)
            bare = hetinv.Pathlength.bins(ctx, [2, 6, 10], 4)
            delta = hetinv.Pathlength.bins_irf(ctx, [2, 6, 10], 4, [0.0], [2.0])
            self.assertEqual(delta.bin_count, 3)
            est = hetinv.Estimator(ctx, photons=300)
            out = []
            for pl in (bare, delta):
                ms = hetinv.Measurements(ctx)
                ms.add(beam, cam, pl)
                out.append(scene.bits(est.render(truth, ms).values))
            self.assertEqual(out[0], out[1])
            with self.assertRaises(hetinv.InvalidArgumentError):
                hetinv.Pathlength.bins_irf(ctx, [2, 6], 4, [0.0, 1.0], [0.0, float("nan")])
            with self.assertRaises(ValueError):  # lengths differ
                hetinv.Pathlength.bins_irf(ctx, [2, 6], 4, [0.0, 1.0], [1.0])

    def test_times_in_picoseconds(self):
        d = list(hetinv.flat(hetinv.irf_offsets_from_times([1000.0, -10.0], eta=1.0)))
        self.assertAlmostEqual(d[0], 299.792458, places=10)
        self.assertAlmostEqual(d[1], -2.99792458, places=12)
        cm = hetinv.flat(hetinv.irf_offsets_from_times([1000.0], eta=1.5, length_unit_mm=10.0))
        self.assertAlmostEqual(cm[0], 299.792458 / 15.0, places=12)
        with self.assertRaises(hetinv.InvalidArgumentError):
            hetinv.irf_offsets_from_times([1.0], eta=0.9)


class Mask(unittest.TestCase):
    def test_saturated_values_are_masked(self):
        with hetinv.Context(seed=4, threads=1) as ctx:
            truth, ms, pm = problem(ctx)
            n = ms.value_count
            ms.set_values([float(i) for i in range(n)])
            self.assertEqual(ms.mask_saturated(n - 2), 2)
            self.assertEqual(list(hetinv.flat(ms.mask)), [1] * (n - 2) + [0, 0])
            with self.assertRaises(hetinv.InvalidArgumentError):
                ms.mask_saturated(float("nan"))


if __name__ == "__main__":
    unittest.main()
