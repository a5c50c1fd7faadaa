"""The optimizer through Python: the progress callable (arguments, stopping,
exceptions, reference kept alive), checkpoint and resume, tunables and
bounds, layer-wise stages and their errors."""
import gc
import os
import tempfile
import unittest

import hetinv
import scene


def problem(ctx, photons=200):
    truth = scene.truth_medium(ctx)
    ms = scene.measurement_set(ctx, truth)
    est = hetinv.Estimator(ctx, photons=photons, batches=8)
    ms.set_values(est.render(truth, ms).values)
    initial = scene.initial_medium(ctx)
    return truth, ms, est, initial


def optimizer(ctx, ms, initial, truth, iterations=(2, 3)):
    opt = hetinv.Optimizer(ctx, ms, initial, method="adam", learning_rate=0.05, average_window=2)
    opt.set_bounds("sigma_s", 1.0, 10.0)
    opt.add_stage(hetinv.ParamMap.coarse(truth, (2, 2, 1), "sigma_s"), iterations=iterations[0])
    opt.add_stage(hetinv.ParamMap.identity(truth, "sigma_s"), iterations=iterations[1])
    return opt


class ProgressCallback(unittest.TestCase):
    def setUp(self):
        self.ctx = hetinv.Context(seed=5, threads=2)
        self.truth, self.ms, self.est, self.initial = problem(self.ctx)

    def tearDown(self):
        self.ctx.close()

    def test_callback_sees_every_iteration(self):
        opt = optimizer(self.ctx, self.ms, self.initial, self.truth)
        seen = []
        opt.set_progress(seen.append)  # returns None: go on
        gc.collect()  # the CFUNCTYPE object must survive: the optimizer holds it
        self.assertEqual(opt.run(self.est), "completed")
        self.assertEqual([p.iteration for p in seen], [1, 2, 3, 4, 5])
        self.assertEqual([p.stage for p in seen], [0, 0, 1, 1, 1])
        self.assertEqual([p.stage_iteration for p in seen], [1, 2, 1, 2, 3])
        self.assertTrue(all(p.stage_count == 2 and p.total_iterations == 5 for p in seen))
        self.assertEqual([p.loss for p in seen], list(opt.losses()))
        self.assertTrue(all(p.step > 0 and p.elapsed >= 0 for p in seen))

    def test_true_return_stops_and_run_continues(self):
        opt = optimizer(self.ctx, self.ms, self.initial, self.truth)
        opt.set_progress(lambda p: p.iteration == 2)
        self.assertEqual(opt.run(self.est), "callback")
        self.assertEqual(len(opt.losses()), 2)
        opt.set_progress(None)
        self.assertEqual(opt.run(self.est), "completed")
        self.assertEqual(len(opt.losses()), 5)

    def test_stopped_and_continued_run_equals_an_uninterrupted_one(self):
        a = optimizer(self.ctx, self.ms, self.initial, self.truth)
        a.run(self.est)
        b = optimizer(self.ctx, self.ms, self.initial, self.truth)
        b.set_progress(lambda p: True)
        for _ in range(5):
            b.run(self.est)
        self.assertEqual(scene.bits(a.losses()), scene.bits(b.losses()))
        self.assertEqual(scene.bits(a.get_pi()), scene.bits(b.get_pi()))

    def test_exception_in_callback_stops_the_run_and_is_raised(self):
        opt = optimizer(self.ctx, self.ms, self.initial, self.truth)

        def boom(p):
            if p.iteration == 3:
                raise KeyError("from the callback")

        opt.set_progress(boom)
        with self.assertRaisesRegex(KeyError, "from the callback"):
            opt.run(self.est)
        self.assertEqual(len(opt.losses()), 3)


class CheckpointResume(unittest.TestCase):
    def test_resumed_run_equals_an_uninterrupted_one(self):
        with tempfile.TemporaryDirectory() as d, hetinv.Context(seed=5, threads=2) as ctx:
            truth, ms, est, initial = problem(ctx)
            whole = optimizer(ctx, ms, initial, truth)
            self.assertEqual(whole.run(est), "completed")

            path = os.path.join(d, "run.ckpt")
            first = optimizer(ctx, ms, initial, truth)
            first.set_checkpoint(path)
            first.set_progress(lambda p: p.iteration == 3)
            self.assertEqual(first.run(est), "callback")
            self.assertTrue(os.path.exists(path))
            first.close()

            second = optimizer(ctx, ms, initial, truth)
            second.resume(path)
            self.assertEqual(second.run(est), "completed")
            self.assertEqual(scene.bits(whole.losses()), scene.bits(second.losses()))
            self.assertEqual(scene.bits(whole.get_pi(True)), scene.bits(second.get_pi(True)))
            self.assertEqual(scene.bits(whole.get_pi(False)), scene.bits(second.get_pi(False)))
            saved = os.path.join(d, "saved.ckpt")
            second.save(saved)
            self.assertGreater(os.path.getsize(saved), 0)
            with whole.result() as r1, second.result() as r2:
                self.assertEqual(scene.bits(r1.grid("sigma_s")), scene.bits(r2.grid("sigma_s")))
                self.assertTrue(r1.committed)

    def test_resume_errors_name_the_problem(self):
        with tempfile.TemporaryDirectory() as d, hetinv.Context(seed=5, threads=1) as ctx:
            truth, ms, est, initial = problem(ctx, photons=50)
            opt = optimizer(ctx, ms, initial, truth)
            with self.assertRaisesRegex(hetinv.FileIOError, "missing.ckpt"):
                opt.resume(os.path.join(d, "missing.ckpt"))
            junk = os.path.join(d, "junk.ckpt")
            with open(junk, "wb") as f:
                f.write(b"junk" * 10)
            with self.assertRaises(hetinv.CorruptFileError):
                opt.resume(junk)


class Configuration(unittest.TestCase):
    def test_tunables_bounds_and_errors(self):
        with hetinv.Context(seed=5, threads=1) as ctx:
            truth, ms, est, initial = problem(ctx, photons=50)
            opt = hetinv.Optimizer(ctx, ms, initial)
            self.assertEqual(opt.get_param("method"), hetinv.METHOD_ADADELTA)
            opt.set_param("method", "sgd").set_param("iterations", 1)
            self.assertEqual(opt.get_param("method"), hetinv.METHOD_SGD)
            self.assertEqual(opt.get_param("coordinates"), hetinv.COORDINATES_NATIVE)
            opt.set_param("coordinates", "reduced")
            self.assertEqual(opt.get_param("coordinates"), hetinv.COORDINATES_REDUCED)
            opt.set_param("coordinates", "log")
            self.assertEqual(opt.get_param("coordinates"), hetinv.COORDINATES_LOG)
            opt.set_param("coordinates", "log-reduced")
            self.assertEqual(opt.get_param("coordinates"), hetinv.COORDINATES_LOG_REDUCED)
            with self.assertRaisesRegex(ValueError, "unknown coordinates"):
                opt.set_param("coordinates", "polar")
            opt.set_param("coordinates", "native")
            self.assertEqual(hetinv.optimizer_param_bounds("average_window"), (1, 4096))
            with self.assertRaisesRegex(hetinv.InvalidArgumentError, "hetinv_optimizer_set_param"):
                opt.set_param("decay", 1.5)
            with self.assertRaisesRegex(hetinv.InvalidArgumentError, "hetinv_optimizer_set_bounds"):
                opt.set_bounds("g", 0.5, 0.2)
            with self.assertRaisesRegex(hetinv.InvalidStateError, "stage"):
                opt.run(est)
            opt.set_bounds("sigma_s", 1.0, float("inf"))
            pmap = hetinv.ParamMap.identity(truth, "sigma_s")
            frozen = [i % 2 == 0 for i in range(pmap.size)]
            opt.add_stage(pmap, frozen=frozen, value_mask=[1] * ms.value_count)
            self.assertEqual(opt.run(est), "completed")
            pi = opt.get_pi(averaged=False)
            self.assertEqual([pi[i] for i in range(0, 16, 2)], [5.0] * 8)  # frozen entries kept
            with self.assertRaisesRegex(hetinv.InvalidStateError, "hetinv_optimizer_set_param"):
                opt.set_param("iterations", 5)

    def test_settling_stage(self):
        """A stage's settling part reaches the library (its values are
        checked there), and runs."""
        with hetinv.Context(seed=5, threads=1) as ctx:
            truth, ms, est, initial = problem(ctx, photons=50)
            pmap = hetinv.ParamMap.identity(truth, "sigma_s")
            opt = hetinv.Optimizer(ctx, ms, initial, average_window=4)
            with self.assertRaisesRegex(hetinv.InvalidArgumentError, "settle_fraction is 1"):
                opt.add_stage(pmap, iterations=4, settle_epsilon=0.001, settle_fraction=1.0)
            with self.assertRaisesRegex(hetinv.InvalidArgumentError, "settle_photons is 0.5"):
                opt.add_stage(pmap, iterations=4, settle_photons=0.5, settle_fraction=0.5)
            opt.add_stage(pmap, iterations=4, epsilon_start=0.05, settle_epsilon=0.001, settle_fraction=0.5)
            opt.add_stage(pmap, iterations=4, settle_photons=2.0, settle_fraction=0.5)
            self.assertEqual(opt.run(est), "completed")
            self.assertEqual(len(opt.losses()), 8)
            self.assertEqual(est.get_param("photons"), 50)  # the estimator's own count, left as it was

    def test_layerwise_stages(self):
        with hetinv.Context(seed=5, threads=1) as ctx:
            truth, ms, est, initial = problem(ctx, photons=50)
            pmap = hetinv.ParamMap.identity(truth, "sigma_s")
            opt = hetinv.Optimizer(ctx, ms, initial, iterations=1)
            opt.add_layerwise_stages(pmap, 1.0, 2, iterations=1)
            self.assertEqual(opt.run(est), "completed")
            self.assertEqual(len(opt.losses()), 2)

            steady_only = hetinv.Measurements(ctx)
            e = hetinv.Emitter.ideal(truth, (1, 4.5, 0.5), (0, -1, 0))
            steady_only.add(e, hetinv.Sensor.hemispherical(truth, "y_max"))
            steady_only.set_values([0.2])
            opt2 = hetinv.Optimizer(ctx, steady_only, initial)
            with self.assertRaisesRegex(hetinv.InvalidArgumentError,
                                        "hetinv_optimizer_add_layerwise_stages"):
                opt2.add_layerwise_stages(pmap, 1.0, 2)


if __name__ == "__main__":
    unittest.main()
