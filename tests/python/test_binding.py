"""The binding's own behaviour: errors carry the library's message and the
right class, handles close deterministically and keep what the C side
borrows alive, the pure-Python array path works, .vol files round-trip."""
import array
import gc
import os
import subprocess
import sys
import tempfile
import unittest

import hetinv
import scene


class Errors(unittest.TestCase):
    def setUp(self):
        self.ctx = hetinv.Context(seed=1, threads=1)

    def tearDown(self):
        self.ctx.close()

    def test_invalid_value_raises_invalid_argument_with_the_library_message(self):
        m = hetinv.Medium(self.ctx, (0, 0, 0), (1, 1, 1), (2, 2, 2))
        with self.assertRaises(hetinv.InvalidArgumentError) as cm:
            m.fill(0.1, -0.3, 0.0)
        e = cm.exception
        self.assertEqual(e.code, 2)
        self.assertEqual(e.name, "HETINV_ERROR_INVALID_ARGUMENT")
        self.assertTrue(str(e).startswith("hetinv_medium_fill:"), str(e))
        self.assertIn("-0.3", str(e))
        self.assertEqual(str(e), self.ctx.last_error_message())
        self.assertEqual(self.ctx.last_error_rank(), 0)  # one rank: every failure is rank 0's
        self.assertIsInstance(e, ValueError)
        self.assertIsInstance(e, hetinv.HetinvError)

    def test_agree_on_one_rank_returns_its_own_status(self):
        self.ctx.agree()
        self.ctx.agree(False)
        with self.assertRaises(hetinv.FileIOError):
            self.ctx.agree(True)

    def test_voxel_outside_the_grid_raises_out_of_range(self):
        m = hetinv.Medium(self.ctx, (0, 0, 0), (1, 1, 1), (2, 2, 2))
        with self.assertRaises(hetinv.OutOfRangeError) as cm:
            m.set_voxel(5, 0, 0, 0.1, 1.0, 0.0)
        self.assertIn("hetinv_medium_set_voxel", str(cm.exception))

    def test_committed_medium_raises_invalid_state(self):
        m = hetinv.Medium(self.ctx, (0, 0, 0), (1, 1, 1), (2, 2, 2)).commit()
        with self.assertRaisesRegex(hetinv.InvalidStateError, "committed"):
            m.set_ior(1.4)

    def test_wrong_grid_length_is_reported_by_the_library(self):
        m = hetinv.Medium(self.ctx, (0, 0, 0), (1, 1, 1), (2, 2, 2))
        with self.assertRaisesRegex(hetinv.InvalidArgumentError, "hetinv_medium_set_grid"):
            m.set_grid("sigma_s", [1.0] * 7)

    def test_missing_file_raises_file_io_error(self):
        with self.assertRaises(hetinv.FileIOError) as cm:
            hetinv.vol_read_header(self.ctx, "/nonexistent/dir/x.vol")
        self.assertIsInstance(cm.exception, OSError)
        self.assertIn("/nonexistent/dir/x.vol", str(cm.exception))

    def test_malformed_file_raises_corrupt_file_error(self):
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "bad.vol")
            with open(path, "wb") as f:
                f.write(b"NOTAVOLFILE" + bytes(40))
            with self.assertRaises(hetinv.CorruptFileError) as cm:
                hetinv.vol_read(self.ctx, path)
            self.assertEqual(cm.exception.name, "HETINV_ERROR_CORRUPT_FILE")

    def test_context_creation_error_has_a_message(self):
        with self.assertRaisesRegex(hetinv.InvalidArgumentError, "thread"):
            hetinv.Context(threads=-1)

    def test_python_side_length_checks(self):
        with self.assertRaisesRegex(ValueError, "box_min: expected 3 values, got 2"):
            hetinv.Medium(self.ctx, (0, 0), (1, 1, 1), (1, 1, 1))
        with self.assertRaisesRegex(ValueError, "unknown face 'top'"):
            hetinv.Sensor.hemispherical(hetinv.Medium(self.ctx, (0, 0, 0), (1, 1, 1), (1, 1, 1)), "top")

    def test_unknown_code_maps_to_the_base_class(self):
        e = hetinv.error_for(99, "from the future")
        self.assertIs(type(e), hetinv.HetinvError)
        self.assertEqual((e.code, e.name), (99, "HETINV_UNKNOWN_RESULT"))

    def test_closed_handle_is_a_python_error(self):
        m = hetinv.Medium(self.ctx, (0, 0, 0), (1, 1, 1), (1, 1, 1))
        m.close()
        with self.assertRaisesRegex(ValueError, "closed Medium"):
            m.fill(0, 0, 0)


class LibrarySearch(unittest.TestCase):
    """Without HETINV_LIBRARY the package finds the library through
    pkg-config, and says where it looked when it finds none."""

    def run_import(self, pc_dir):
        env = {k: v for k, v in os.environ.items()
               if k not in ("HETINV_LIBRARY", "LD_LIBRARY_PATH", "PKG_CONFIG_PATH")}
        env["PKG_CONFIG_PATH"] = env["PKG_CONFIG_LIBDIR"] = pc_dir  # no system .pc files
        return subprocess.run([sys.executable, "-c", "import hetinv; print(hetinv.library_path)"],
                              env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              universal_newlines=True)

    def setUp(self):
        import ctypes.util

        if ctypes.util.find_library("hetinv") or any(
                os.path.exists(os.path.join(d, hetinv._lib.SONAME))
                for d in hetinv._lib.COMMON_LIBDIRS):
            self.skipTest("a libhetinv is installed on this system: it would be found first")

    def test_found_through_pkg_config(self):
        libdir = os.path.dirname(os.path.realpath(hetinv.library_path))
        with tempfile.TemporaryDirectory() as d:
            with open(os.path.join(d, "hetinv.pc"), "w") as f:
                f.write("prefix=/nowhere\nlibdir=%s\n\nName: hetinv\nDescription: test\n"
                        "Version: %s\nLibs: -L${libdir} -lhetinv\n" % (libdir, hetinv.version()))
            r = self.run_import(d)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(r.stdout.strip(), os.path.join(libdir, "libhetinv.so.0"))

    def test_not_found_lists_where_it_looked(self):
        with tempfile.TemporaryDirectory() as d:
            r = self.run_import(d)
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("ImportError: hetinv: cannot load libhetinv", r.stderr)
        for place in ["ctypes.util.find_library: nothing found", "pkg-config libdir: nothing found",
                      "the dynamic loader (LD_LIBRARY_PATH)"] + list(hetinv._lib.COMMON_LIBDIRS):
            self.assertIn(place, r.stderr)


class Lifetimes(unittest.TestCase):
    def test_with_closes_at_the_end_of_the_block(self):
        with hetinv.Context(seed=7) as ctx:
            with hetinv.Medium(ctx, (0, 0, 0), (1, 1, 1), (1, 1, 1)) as m:
                self.assertFalse(m.closed)
            self.assertTrue(m.closed)
            self.assertFalse(ctx.closed)
        self.assertTrue(ctx.closed)
        ctx.close()  # twice is fine

    def test_closing_a_context_closes_everything_made_from_it_first(self):
        ctx = hetinv.Context(seed=7, threads=1)
        truth = scene.truth_medium(ctx)
        ms = scene.measurement_set(ctx, truth)
        est = hetinv.Estimator(ctx, photons=10)
        pmap = hetinv.ParamMap.identity(truth)
        opt = hetinv.Optimizer(ctx, ms, truth)
        opt.add_stage(pmap)
        ctx.close()
        for obj in (truth, ms, est, pmap, opt):
            self.assertTrue(obj.closed, obj)

    def test_set_keeps_its_sampling_functions_alive(self):
        with hetinv.Context(seed=7, threads=1) as ctx:
            truth = scene.truth_medium(ctx)
            ms = scene.measurement_set(ctx, truth)  # the emitters etc. are only referenced by ms
            gc.collect()
            est = hetinv.Estimator(ctx, photons=100)
            self.assertEqual(len(est.render(truth, ms).values), 27)

    def test_closing_a_borrowed_object_closes_its_borrowers(self):
        with hetinv.Context(seed=7, threads=1) as ctx:
            m = scene.truth_medium(ctx)
            e = hetinv.Emitter.ideal(m, (1, 4.5, 0.5), (0, -1, 0))
            s = hetinv.Sensor.hemispherical(m, "y_max")
            ms = hetinv.Measurements(ctx)
            ms.add(e, s)
            ms.set_values([0.1])
            opt = hetinv.Optimizer(ctx, ms, m)
            e.close()
            self.assertTrue(ms.closed)
            self.assertTrue(opt.closed)
            self.assertFalse(s.closed)

    def test_optimizer_keeps_set_maps_and_medium_alive(self):
        with hetinv.Context(seed=7, threads=1) as ctx:
            opt = _small_optimizer(ctx)
            gc.collect()
            opt.run(hetinv.Estimator(ctx, photons=50))
            self.assertEqual(len(opt.losses()), 2)

    def test_unreferenced_handles_are_freed_by_refcount(self):
        ctx = hetinv.Context()
        m = hetinv.Medium(ctx, (0, 0, 0), (1, 1, 1), (1, 1, 1))
        self.assertEqual(len(ctx._deps), 1)
        del m
        self.assertEqual(len(ctx._deps), 0)
        ctx.close()


def _small_optimizer(ctx):
    truth = scene.truth_medium(ctx)
    ms = scene.measurement_set(ctx, truth)
    ms.set_values(hetinv.Estimator(ctx, photons=50).render(truth, ms).values)
    opt = hetinv.Optimizer(ctx, ms, scene.initial_medium(ctx))
    opt.add_stage(hetinv.ParamMap.identity(truth, "sigma_s"), iterations=2)
    return opt


class Objects(unittest.TestCase):
    def setUp(self):
        self.ctx = hetinv.Context(seed=3, threads=2)
        self.previous = hetinv.use_numpy(False) if hetinv.numpy_available() else False

    def tearDown(self):
        self.ctx.close()
        if self.previous:
            hetinv.use_numpy(True)

    def test_version_and_context(self):
        self.assertRegex(hetinv.version(), r"^\d+\.\d+\.\d+$")
        self.assertGreater(hetinv.version_number(), 0)
        self.assertEqual(self.ctx.seed, 3)
        self.assertEqual(self.ctx.thread_count, 2)
        self.assertEqual(hetinv.result_name(7), "HETINV_ERROR_CORRUPT_FILE")

    def test_medium_accessors_and_clone(self):
        m = scene.truth_medium(self.ctx)
        self.assertEqual(m.dims, (4, 4, 1))
        self.assertEqual(m.voxel_count, 16)
        self.assertEqual(m.box, ((0, 0, 0), (4, 4, 1)))
        self.assertEqual(m.ior, (1.3, 1.0))
        self.assertTrue(m.committed)
        self.assertEqual(m.get_voxel(1, 1, 0), (0.1, 8.0, 0.5))
        sigma_s = m.grid("sigma_s")
        self.assertIsInstance(sigma_s, array.array)
        self.assertEqual(sigma_s[1 + 4 * 1], 8.0)
        c = m.clone()
        self.assertFalse(c.committed)
        c.set_grid(hetinv.PARAM_G, array.array("d", [0.25] * 16))
        self.assertEqual(list(c.grid("g")), [0.25] * 16)
        self.assertEqual(list(m.grid("g")), [0.5] * 16)
        with self.assertRaises(hetinv.OutOfRangeError):
            m.grid(7)

    def test_vol_round_trip(self):
        m = scene.truth_medium(self.ctx)
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "sigma_s.vol")
            m.write_vol("sigma_s", path)
            header, data = hetinv.vol_read(self.ctx, path)
            self.assertEqual((list(header.dims), header.channels), ([4, 4, 1], 1))
            self.assertEqual(list(header.box_max), [4, 4, 1])
            self.assertEqual(list(data), list(m.grid("sigma_s")))
            c = hetinv.Medium(self.ctx, (0, 0, 0), (4, 4, 1), (4, 4, 1)).read_vol("sigma_s", path)
            self.assertEqual(list(c.grid("sigma_s")), list(m.grid("sigma_s")))
            other = os.path.join(d, "other.vol")
            hetinv.vol_write(self.ctx, other, [1.5, 2.5], (2, 1, 1), box_max=(2, 1, 1))
            self.assertEqual(list(hetinv.vol_read(self.ctx, other)[1]), [1.5, 2.5])

    def test_fiber_probe(self):
        m = scene.truth_medium(self.ctx)
        # Over the whole y_min face (4 x 1 around (2, 0.5)) with NA = n_out it
        # is that face's hemispherical detector, on the same photons.
        fiber = hetinv.Sensor.fiber(m, "y_min", (2, 0.5), 2.5, 1.0)
        self.assertEqual((fiber.pixel_count, fiber.size), (1, (1, 1)))
        hemi = hetinv.Sensor.hemispherical(m, "y_min")
        beam = hetinv.Emitter.ideal(m, (1, 4.5, 0.5), (0, -1, 0))
        values = []
        for s in (fiber, hemi):
            ms = hetinv.Measurements(self.ctx)
            ms.add(beam, s)
            values.append(list(hetinv.Estimator(self.ctx, photons=500).render(m, ms).values))
        self.assertEqual(values[0], values[1])
        self.assertGreater(values[0][0], 0.0)
        with self.assertRaisesRegex(hetinv.InvalidArgumentError, "numerical_aperture is 0"):
            hetinv.Sensor.fiber(m, "y_min", (2, 0.5), 0.1, 0.0)
        with self.assertRaisesRegex(hetinv.InvalidArgumentError, "centre\\[0\\] \\(x\\) is 5"):
            hetinv.Sensor.fiber(m, "y_min", (5, 0.5), 0.1, 0.22)
        with self.assertRaisesRegex(TypeError, "radius"):
            hetinv.Sensor.fiber(m, "y_min", (2, 0.5), "wide", 0.22)

    def test_sampling_functions_and_layout(self):
        m = scene.truth_medium(self.ctx)
        area = hetinv.Emitter.area(m, "y_max", (0, -1, 0), (0, 0), (4, 1),
                                   pattern=[1, 2, 3, 4], pattern_shape=(4, 1))
        combo = hetinv.Emitter.combination(m, [(1, 4.5, 0.5), (3, 4.5, 0.5)],
                                           [(0, -1, 0), (0, -1, 0)], [0.5, 1.5])
        cam = hetinv.Sensor.orthographic(m, "y_max", (0, 1, 0), (0, 0), (1, 1), 4, 1)
        self.assertEqual((cam.pixel_count, cam.size), (4, (4, 1)))
        hemi = hetinv.Sensor.hemispherical(m, "y_min", (0, 0), (4, 1))
        self.assertEqual(hemi.size, (1, 1))
        bins = hetinv.Pathlength.bins(self.ctx, [1, 2, 3], 0.5, window="gaussian")
        self.assertEqual(bins.bin_count, 3)
        ms = hetinv.Measurements(self.ctx)
        self.assertEqual(ms.add(area, cam, bins), 0)
        self.assertEqual(ms.add(combo, hemi), 1)
        self.assertEqual((ms.row_count, ms.value_count), (2, 13))
        self.assertEqual(ms.layout(1), (12, 1, 1))
        ms.set_values([0.5] * 13, [0.1] * 13).set_weights([2.0] * 13)
        ms.set_mask([True] * 12 + [False])
        self.assertEqual(list(ms.values), [0.5] * 13)
        self.assertEqual(list(ms.std_errors), [0.1] * 13)
        self.assertEqual(list(ms.weights), [2.0] * 13)
        self.assertEqual(list(ms.mask), [1] * 12 + [0])
        self.assertEqual(list(ms.clip_scales_below), [1.0] * 13)
        ms.set_clip_scales(above=[3.0] * 13)
        self.assertEqual(list(ms.clip_scales_below), [1.0] * 13)
        self.assertEqual(list(ms.clip_scales_above), [3.0] * 13)
        ms.set_clip_scales([2.0] * 13, [4.0] * 13)
        self.assertEqual((ms.clip_scales_below[0], ms.clip_scales_above[12]), (2.0, 4.0))
        with self.assertRaisesRegex(hetinv.InvalidArgumentError, "below\\[0\\].*must be finite and > 0"):
            ms.set_clip_scales([0.0] * 13)
        with self.assertRaisesRegex(hetinv.OutOfRangeError, "hetinv_measurements_row_layout"):
            ms.layout(5)
        with self.assertRaisesRegex(hetinv.InvalidArgumentError, "hetinv_measurements_set_values"):
            ms.set_values([float("nan")] * 13)
        est = hetinv.Estimator(self.ctx, photons=500)
        r = est.render(m, ms)
        self.assertEqual(len(r.values), 13)
        self.assertEqual(est.stats().photons, 1000)

    def test_estimator_params(self):
        est = hetinv.Estimator(self.ctx, photons=1234, roulette_weight=0.0)
        self.assertEqual(est.get_param("photons"), 1234)
        self.assertEqual(est.get_param(2), 0.0)
        lo, hi = hetinv.estimator_param_bounds("batches")
        self.assertEqual((lo, hi), (2, 65536))
        with self.assertRaisesRegex(hetinv.InvalidArgumentError, "hetinv_estimator_set_param"):
            est.set_param("batches", 1)
        with self.assertRaises(hetinv.OutOfRangeError):
            est.set_param(99, 1)
        with self.assertRaisesRegex(hetinv.InvalidStateError, "hetinv_estimator_get_stats"):
            est.stats()

    def test_param_maps(self):
        m = scene.truth_medium(self.ctx)
        ident = hetinv.ParamMap.identity(m, ("sigma_a", "sigma_s"))
        self.assertEqual((ident.size, ident.free_mask, ident.dims), (32, 3, (4, 4, 1)))
        self.assertEqual(ident.entry(17), (hetinv.PARAM_SIGMA_S, 1))
        pi = ident.extract(m)
        self.assertEqual(pi[16 + 5], 8.0)
        c = m.clone()
        ident.apply([0.3] * 16 + [2.0] * 16, c)
        self.assertEqual(c.get_voxel(0, 0, 0), (0.3, 2.0, 0.5))
        grad = ident.pullback([1.0] * 48)
        self.assertEqual(list(grad), [1.0] * 32)
        coarse = hetinv.ParamMap.coarse(m, (2, 2, 1), hetinv.FREE_ALL)
        self.assertEqual((coarse.size, coarse.dims), (12, (2, 2, 1)))
        flat = hetinv.ParamMap.broadcast(m, 1, "g")
        self.assertEqual((flat.size, flat.dims), (4, (4, 1, 1)))
        with self.assertRaisesRegex(hetinv.InvalidArgumentError, "hetinv_param_map_create_identity"):
            hetinv.ParamMap.identity(m, 0)


class Bound(unittest.TestCase):
    """The tangent pass and the Cramér–Rao bound through the binding (the C
    functions are validated in tests/validation/test_bound.c)."""

    def test_jvp_matches_the_gradient_pass_and_the_bound_is_shaped(self):
        with hetinv.Context(seed=3, threads=1) as ctx:
            m = hetinv.Medium(ctx, (0, 0, 0), (1, 1, 1), (2, 1, 2)).set_ior(1.0, 1.0)
            m.fill(0.5, 5.0, 0.3)
            m.commit()
            beam = hetinv.Emitter.ideal(m, (0.5, 0.5, 2.0), (0, 0, -1))
            top = hetinv.Sensor.orthographic(m, "z_max", (0, 0, 1), (0, 0), (0.5, 1.0), 2, 1)
            rows = hetinv.Measurements(ctx)
            rows.add(beam, top)
            pmap = hetinv.ParamMap.identity(m, ("sigma_a", "sigma_s"))
            est = hetinv.Estimator(ctx, photons=4000)
            u = [1.0, -0.5]
            v = [0.3, -0.2, 0.1, 0.4, -0.1, 0.2, 0.05, -0.3]
            jv = est.jvp(m, rows, pmap, v)
            grad = est.gradient(m, rows, u, pmap)
            lhs = sum(a * b for a, b in zip(u, hetinv.flat(jv.grad)))
            rhs = sum(a * b for a, b in zip(hetinv.flat(grad.grad), v))
            # The same photons (same stream) carry the same scores: equal up to rounding.
            self.assertAlmostEqual(lhs, rhs, delta=1e-9 * (abs(lhs) + abs(rhs)) + 1e-300)
            with self.assertRaisesRegex(ValueError, "tangent"):
                est.jvp(m, rows, pmap, v[:3])
            b = est.crb(m, rows, [1e-6, 1e-6], pmap, replicates=4)
            sd = list(hetinv.flat(b.sd))
            self.assertEqual(len(sd), pmap.size)
            if hetinv.numpy_enabled():
                self.assertEqual(b.sd.shape, tuple(pmap.shape))
            lower = list(hetinv.flat(b.lower))
            for lo, s in zip(lower, sd):
                self.assertGreater(lo, 0.0)
                if b.positive_definite:
                    self.assertGreaterEqual(s, lo * (1 - 1e-12))
            f = est.fisher(m, rows, [1e-6, 1e-6], pmap, replicates=4)
            local = list(hetinv.flat(pmap.local_crb(f.fisher, radius=0)))
            self.assertEqual(len(local), pmap.size)
            with self.assertRaisesRegex(ValueError, "fisher"):
                pmap.local_crb([1.0, 2.0])
            # The blocks (here each cell's 2 x 2) give the same local bound at
            # radius 0 when they are the dense matrix's own blocks.
            blocks = est.fisher_blocks(m, rows, [1e-6, 1e-6], pmap, spacing=2, replicates=2)
            self.assertEqual(len(list(hetinv.flat(blocks.grad))), pmap.size * 2)
            if hetinv.numpy_enabled():
                self.assertEqual(blocks.grad.shape, tuple(pmap.shape[1:]) + (2, 2))
            K, cells = pmap.size, pmap.size // 2
            F = list(hetinv.flat(f.fisher))
            own = [F[(a * cells + c) * K + b * cells + c] for c in range(cells) for a in range(2) for b in range(2)]
            from_blocks = list(hetinv.flat(pmap.blocks_crb(own)))
            for x, y in zip(from_blocks, local):
                if x == x and y == y:  # NaN where a block is not positive definite
                    self.assertAlmostEqual(x, y, delta=1e-12 * abs(y))
            with self.assertRaisesRegex(ValueError, "blocks"):
                pmap.blocks_crb([1.0, 2.0])


if __name__ == "__main__":
    unittest.main()
