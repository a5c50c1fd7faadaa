"""The binding computes the same bits as the C API: the scene of
c_reference.c rendered, differentiated, noised and optimised through
Python, every double compared exactly (struct-packed bytes) with the C
program's "%a" output."""
import unittest

import hetinv
import scene


class EqualityWithC(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.ref, cls.sizes = scene.c_reference()
        cls.py = {}
        py = cls.py
        with hetinv.Context(seed=7, threads=2) as ctx:
            truth = scene.truth_medium(ctx)
            ms = scene.measurement_set(ctx, truth)
            est = hetinv.Estimator(ctx, photons=3000, batches=16)
            r = est.render(truth, ms)
            py["render.values"], py["render.std_errors"], py["render.ballistic"] = r
            s = est.stats()
            py["stats.photons"] = [float(s.photons)]
            py["stats.specular"] = [s.specular]
            py["stats.absorbed"] = [s.absorbed]
            py["stats.escaped"] = list(s.escaped)

            noisy = hetinv.apply_noise(ctx, r.values, seed=11, read_noise=2.0)
            py["noise.values"], py["noise.std_errors"] = noisy.values, noisy.std_errors
            py["noise.exposure"] = [noisy.exposure]
            ms.set_values(noisy.values, noisy.std_errors)

            fine = hetinv.ParamMap.identity(truth, "sigma_s")
            coarse = hetinv.ParamMap.coarse(truth, (2, 2, 1), free=hetinv.FREE_SIGMA_S)
            g = est.gradient(truth, ms, [1.0] * ms.value_count, fine)
            py["gradient.grad"], py["gradient.std_errors"] = g

            initial = scene.initial_medium(ctx)
            lg = est.loss_gradient(initial, ms, fine)
            py["loss_gradient.loss"] = [lg.loss]
            py["loss_gradient.grad"] = lg.grad
            py["loss_gradient.rendered"] = lg.rendered

            opt = hetinv.Optimizer(ctx, ms, initial, average_window=2)
            opt.set_bounds("sigma_s", 1.0, 10.0)
            opt.add_stage(coarse, iterations=3)
            opt.add_stage(fine, iterations=3)
            est.set_param("photons", 1000)
            reason = opt.run(est)
            py["optimizer.reason"] = [float(hetinv.optimizer.STOP_REASONS_INV[reason])]
            py["optimizer.losses"] = opt.losses()
            py["optimizer.pi_averaged"] = opt.get_pi(averaged=True)
            py["optimizer.pi_last"] = opt.get_pi(averaged=False)
            with opt.result() as result:
                for p in ("sigma_a", "sigma_s", "g"):
                    py["optimizer.result." + p] = result.grid(p)

            vol = hetinv.Medium(ctx, (0, 0, 0), (5, 4, 3), (5, 4, 3))
            vol.fill_gaussian_mixture(seed=3, constant_axis=2, components=3)
            for p in ("sigma_a", "sigma_s", "g"):
                py["mixture." + p] = vol.grid(p)
            spec = hetinv.SmokeSpec(seed=4)
            spec.octaves = 2
            vol.fill_smoke(spec)
            for p in ("sigma_a", "sigma_s", "g"):
                py["smoke." + p] = vol.grid(p)

    def check(self, key):
        self.assertIn(key, self.ref, "c_reference printed no %s" % key)
        ref, got = self.ref[key], list(hetinv.flat(self.py[key]))  # C order
        self.assertEqual(len(got), len(ref), key)
        if scene.bits(got) != scene.bits(ref):
            self.fail("%s differs from the C API:\n python %s\n C      %s"
                      % (key, scene.hexes(got), scene.hexes(ref)))

    def test_every_key_of_the_c_program_is_compared(self):
        self.assertEqual(sorted(self.ref), sorted(self.py))

    def test_struct_sizes_match_the_c_compiler(self):
        import ctypes
        from hetinv import _structs

        mirrors = {"context_init": _structs.ContextInit, "vol_header": _structs.VolHeader,
                   "render_stats": _structs.RenderStats, "stage": _structs.Stage,
                   "progress": _structs.Progress, "noise_model": _structs.NoiseModel,
                   "mixture_spec": _structs.MixtureSpec, "smoke_spec": _structs.SmokeSpec}
        self.assertEqual(sorted(mirrors), sorted(self.sizes))
        for name, cls in mirrors.items():
            self.assertEqual(ctypes.sizeof(cls), self.sizes[name], name)

    def test_render_equals_c(self):
        for k in ("render.values", "render.std_errors", "render.ballistic"):
            self.check(k)

    def test_render_stats_equal_c(self):
        for k in ("stats.photons", "stats.specular", "stats.absorbed", "stats.escaped"):
            self.check(k)

    def test_noise_equals_c(self):
        for k in ("noise.values", "noise.std_errors", "noise.exposure"):
            self.check(k)

    def test_gradient_equals_c(self):
        self.check("gradient.grad")
        self.check("gradient.std_errors")

    def test_loss_gradient_equals_c(self):
        for k in ("loss_gradient.loss", "loss_gradient.grad", "loss_gradient.rendered"):
            self.check(k)

    def test_optimizer_iterations_equal_c(self):
        self.assertEqual(len(self.py["optimizer.losses"]), 6)
        for k in ("optimizer.reason", "optimizer.losses", "optimizer.pi_averaged",
                  "optimizer.pi_last", "optimizer.result.sigma_a", "optimizer.result.sigma_s",
                  "optimizer.result.g"):
            self.check(k)

    def test_volume_generators_equal_c(self):
        for kind in ("mixture", "smoke"):
            for p in ("sigma_a", "sigma_s", "g"):
                self.check("%s.%s" % (kind, p))


if __name__ == "__main__":
    unittest.main()
