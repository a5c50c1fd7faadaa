"""Python code must never crash the interpreter or silently corrupt data
through the binding (issue 13): destruction order under the garbage
collector, handle types, lengths of arrays, ranges of integers.

Code that crashed before the binding checked it runs in a child process (a
segfault there fails one test instead of killing the run). The child runs
with MALLOC_PERTURB_ set, so that glibc fills freed memory and a
use-after-free of a context (its allocator hooks are read from it) crashes
every time instead of only sometimes.
"""
import os
import subprocess
import sys
import textwrap
import unittest

# What every child starts from: a context, a medium and one of every object.
PREAMBLE = """
import gc, sys
import hetinv
ctx = hetinv.Context(seed=1, threads=1)
m = hetinv.Medium(ctx, (0, 0, 0), (2, 2, 1), (2, 2, 1)).fill(0.1, 2.0, 0.0).commit()
e = hetinv.Emitter.ideal(m, (0.5, 0.5, 1.5), (0, 0, -1))
s = hetinv.Sensor.hemispherical(m, "z_min")
p = hetinv.Pathlength.steady(ctx)
ms = hetinv.Measurements(ctx)
ms.add(e, s, p)
ms.set_values([0.5])
est = hetinv.Estimator(ctx, photons=20)
pmap = hetinv.ParamMap.identity(m, "sigma_s")
opt = hetinv.Optimizer(ctx, ms, m)

def expect(exc, fn, *args, **kw):
    try:
        fn(*args, **kw)
    except exc as x:
        print("raised", type(x).__name__, x)
    else:
        print("accepted")
        sys.exit(3)
"""


def run_child(code, preamble=True):
    """(exit status, stdout + stderr) of a child python running `code`."""
    env = dict(os.environ, MALLOC_PERTURB_="165")
    src = (PREAMBLE if preamble else "") + textwrap.dedent(code) + "\nprint('child done')\n"
    proc = subprocess.run([sys.executable, "-c", src], env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, universal_newlines=True, timeout=120)
    return proc.returncode, proc.stdout


class ChildTest(unittest.TestCase):
    def assertChildOk(self, code, expect_in=(), preamble=True):
        rc, out = run_child(code, preamble)
        self.assertEqual(rc, 0, "child exited with %d (negative: killed by signal %d):\n%s"
                         % (rc, -rc, out))
        self.assertIn("child done", out)
        for text in expect_in:
            self.assertIn(text, out)
        return out


class DestructionOrder(ChildTest):
    """A cycle holding a context and objects made from it is collected with
    the context destroyed last."""

    def test_cycle_with_context_and_medium(self):
        self.assertChildOk("""
            import gc, hetinv
            gc.disable()
            for i in range(20):
                c = hetinv.Context(seed=1, threads=1)
                md = hetinv.Medium(c, (0, 0, 0), (1, 1, 1), (2, 2, 2))
                cyc = [md, c] if i % 2 else [c, md]
                cyc.append(cyc)
                del c, md, cyc
                gc.collect()
        """, preamble=False)

    def test_cycle_with_every_kind_of_object(self):
        self.assertChildOk("""
            gc.disable()
            opt.add_stage(pmap, iterations=1)
            objs = [ctx, m, e, s, p, ms, est, pmap, opt, m.clone()]
            for i in range(6):
                cyc = objs[i:] + objs[:i]
                cyc.append(cyc)
                del cyc
            del ctx, m, e, s, p, ms, est, pmap, opt, objs
            gc.collect()
        """)

    def test_exception_in_progress_callback_then_collect(self):
        # The exception's traceback and the callback tie the optimizer, its
        # context and the caller's frame into a cycle.
        self.assertChildOk("""
            gc.disable()
            def boom(progress):
                raise KeyError("from the callback")
            opt.add_stage(pmap, iterations=3)
            opt.set_progress(boom)
            try:
                opt.run(est)
            except KeyError as x:
                caught = x
            print("caught", repr(caught))
            del ctx, m, e, s, p, ms, est, pmap, opt, caught, boom
            gc.collect()
        """, expect_in=["caught KeyError('from the callback')"])

    def test_callback_exception_is_reraised_with_its_type(self):
        self.assertChildOk("""
            opt.add_stage(pmap, iterations=5)
            calls = []
            def stop(progress):
                calls.append(progress.iteration)
                raise ValueError("stop here")
            opt.set_progress(stop)
            expect(ValueError, opt.run, est)
            assert calls == [1], calls
        """)

    def test_closing_what_a_running_optimizer_uses_is_refused(self):
        # Closing the context (or the set, or the estimator) from the
        # progress callback would destroy the optimizer under its own run.
        self.assertChildOk("""
            opt.add_stage(pmap, iterations=10)
            for victim in (ctx, ms, e, est, pmap, opt):
                def close_it(progress, victim=victim):
                    victim.close()
                opt.set_progress(close_it)
                expect(RuntimeError, opt.run, est)
                assert not victim.closed
            expect(RuntimeError, lambda: opt.set_progress(lambda pr: opt.run(est)) and opt.run(est))
            def replace(progress):
                opt.set_progress(None)  # the running callback removes itself
            opt.set_progress(replace)
            assert opt.run(est) == "completed"
            ctx.close()
            assert opt.closed and ms.closed and e.closed
        """)

    def test_closing_from_another_thread_during_a_render_is_refused(self):
        # ctypes releases the GIL during the render: another thread can call close().
        self.assertChildOk("""
            import threading, time
            big = hetinv.Estimator(ctx, photons=400000)  # about 0.3 s
            started, result = threading.Event(), []
            def work():
                started.set()
                try:
                    result.append(len(big.render(m, ms).values))
                except ValueError as x:  # the close won the race: a Python error
                    result.append(str(x))
            t = threading.Thread(target=work)
            t.start()
            started.wait()
            time.sleep(0.02)
            refused = 0
            while t.is_alive():
                try:
                    ctx.close()
                except RuntimeError:
                    refused += 1
                time.sleep(0.002)
            t.join()
            print("refused", refused, "result", result)
            assert result == [1] if refused else "closed" in result[0], result
            ctx.close()
            assert m.closed and big.closed
        """, expect_in=["refused"])

    def test_growing_a_set_an_optimizer_uses_is_refused(self):
        # The optimizer's stage masks are value_count long; a longer set would be read past them.
        self.assertChildOk("""
            opt.add_stage(pmap, value_mask=[1])
            expect(RuntimeError, ms.add, e, s, p)
            opt.close()
            ms.add(e, s, p)
        """)


class HandleTypes(ChildTest):
    """A handle of the wrong class is a TypeError, never a C call."""

    def test_medium_with_a_medium_as_its_context(self):
        self.assertChildOk("""
            expect(TypeError, hetinv.Medium, m, (0, 0, 0), (1, 1, 1), (1, 1, 1))
        """, expect_in=["raised TypeError ctx: expected hetinv.Context, got hetinv.Medium"])

    def test_row_with_sensor_and_emitter_swapped(self):
        self.assertChildOk("""
            expect(TypeError, ms.add, s, e)
            expect(TypeError, ms.add, e, s, ctx)
            assert ms.row_count == 1
        """, expect_in=["raised TypeError emitter: expected hetinv.Emitter, got hetinv.Sensor"])

    def test_every_wrapper_checks_its_handles(self):
        self.assertChildOk("""
            calls = [
                lambda: hetinv.Medium(None, (0, 0, 0), (1, 1, 1), (1, 1, 1)),
                lambda: hetinv.Emitter.ideal(ctx, (0.5, 0.5, 1.5), (0, 0, -1)),
                lambda: hetinv.Emitter.area(s, "z_max", (0, 0, -1), (0, 0), (1, 1)),
                lambda: hetinv.Emitter.diffuse(ms, "z_max", (0.5, 0.5)),
                lambda: hetinv.Emitter.combination(e, [(0.5, 0.5, 1.5)], [(0, 0, -1)], [1]),
                lambda: hetinv.Sensor.orthographic(ctx, "z_max", (0, 0, 1), (0, 0), (1, 1), 1, 1),
                lambda: hetinv.Sensor.hemispherical(est, "z_min"),
                lambda: hetinv.Pathlength.steady(m),
                lambda: hetinv.Pathlength.bins(m, [1], 1),
                lambda: hetinv.Measurements(m),
                lambda: ms.add(e, e, p),
                lambda: hetinv.Estimator(m),
                lambda: est.render(ms, m),
                lambda: est.render(m, pmap),
                lambda: est.gradient(m, ms, [1.0], ms),
                lambda: est.loss_gradient(m, ms, m),
                lambda: hetinv.ParamMap.identity(ctx),
                lambda: hetinv.ParamMap.coarse(ctx, (1, 1, 1)),
                lambda: hetinv.ParamMap.broadcast(ctx, 0),
                lambda: pmap.apply([1.0] * 4, ctx),
                lambda: pmap.extract(ms),
                lambda: hetinv.Optimizer(m, ms, m),
                lambda: hetinv.Optimizer(ctx, m, ms),
                lambda: hetinv.Optimizer(ctx, ms, ctx),
                lambda: opt.add_stage(m),
                lambda: opt.add_layerwise_stages(ms, 1.0, 1),
                lambda: opt.run(ctx),
                lambda: hetinv.apply_noise(m, [1.0]),
                lambda: hetinv.vol_read_header(m, "x.vol"),
                lambda: hetinv.vol_read(m, "x.vol"),
                lambda: hetinv.vol_write(m, "x.vol", [1.0], (1, 1, 1)),
                lambda: hetinv.apply_noise(ctx, [1.0], model=hetinv.MixtureSpec()),
                lambda: m.clone().fill_gaussian_mixture(hetinv.SmokeSpec()),
                lambda: m.clone().fill_smoke(hetinv.NoiseModel()),
            ]
            for i, call in enumerate(calls):
                print(i, end=" ")
                expect(TypeError, call)
        """)


class Lengths(ChildTest):
    """Every array the C side reads a fixed count of is checked first."""

    def test_short_and_long_stage_masks(self):
        out = self.assertChildOk("""
            pm = hetinv.ParamMap.identity(m, "sigma_s")  # 4 entries
            expect(ValueError, opt.add_stage, pm, frozen=[0])
            expect(ValueError, opt.add_stage, pm, frozen=[0] * 5)
            expect(ValueError, opt.add_stage, pm, value_mask=[])
            expect(ValueError, opt.add_stage, pm, value_mask=[1, 1])
            opt.add_stage(pm, frozen=[0, 1, 0, 0], value_mask=[1])
        """)
        self.assertIn("frozen: expected 4 values, got 1", out)
        self.assertIn("value_mask: expected 1 values, got 0", out)

    def test_short_voxel_gradient(self):
        self.assertChildOk("""
            expect(ValueError, pmap.pullback, [1.0])
            assert list(hetinv.flat(pmap.pullback([1.0] * 12))) == [1.0] * 4
        """, expect_in=["voxel_grad: expected 12 values, got 1"])

    def test_fixed_vectors_and_patterns(self):
        self.assertChildOk("""
            expect(ValueError, hetinv.Emitter.area, m, "z_max", (0, 0, -1), (0, 0), (1, 1),
                   pattern=[1, 2, 3], pattern_shape=(2, 2))
            expect(ValueError, hetinv.Emitter.combination, m, [(0.5, 0.5, 1.5)], [(0, 0)], [1])
            # Vectors of other lengths whose total is right were regrouped
            # into other sources: each vector is checked.
            expect(ValueError, hetinv.Emitter.combination, m, [(0.5, 0.5), (-1, 0.5, 0.5, -1)],
                   [(0, 0, 1), (0, 0, 1)], [1, 1])
            expect(ValueError, hetinv.Emitter.combination, m, [0.5, 0.5, -1, (0.5, 0.5, -1)],
                   [(0, 0, 1), (0, 0, 1)], [1, 1])
            hetinv.Emitter.combination(m, [0.5, 0.5, -1, 0.5, 0.5, -1], [(0, 0, 1), (0, 0, 1)], [1, 1])
            expect(ValueError, hetinv.vol_write, ctx, "x.vol", [1.0], (1, 1))
            expect(ValueError, hetinv.ParamMap.coarse, m, (1, 1))
        """)


class Ranges(ChildTest):
    """An integer that does not fit its C type is an error, not a wrapped value."""

    def test_voxel_index_does_not_wrap(self):
        self.assertChildOk("""
            md = hetinv.Medium(ctx, (0, 0, 0), (1, 1, 1), (2, 2, 2)).fill(0.1, 1.0, 0.0)
            expect(OverflowError, md.set_voxel, 2**32, 0, 0, 0.5, 2.0, 0.0)
            expect(OverflowError, md.set_voxel, 0, -2**32, 0, 0.5, 2.0, 0.0)
            expect(OverflowError, md.get_voxel, 0, 0, 2**32)
            assert md.get_voxel(0, 0, 0) == (0.1, 1.0, 0.0), md.get_voxel(0, 0, 0)
        """, expect_in=["ix: 4294967296 is outside the range of int32"])

    def test_integer_arguments_are_range_checked(self):
        self.assertChildOk("""
            md = hetinv.Medium(ctx, (0, 0, 0), (1, 1, 1), (2, 2, 2))
            big = 2**32 + 1
            calls = [
                lambda: hetinv.Context(seed=2**64),
                lambda: hetinv.Context(seed=-1),
                lambda: hetinv.Context(threads=big),
                lambda: hetinv.Medium(ctx, (0, 0, 0), (1, 1, 1), (big, 1, 1)),
                lambda: md.set_grid(big, [1.0] * 8),
                lambda: md.grid(big),
                lambda: md.write_vol(big, "x.vol"),
                lambda: hetinv.Sensor.orthographic(m, "z_max", (0, 0, 1), (0, 0), (1, 1), big, 1),
                lambda: hetinv.Sensor.hemispherical(m, big),
                lambda: hetinv.Emitter.area(m, "z_max", (0, 0, -1), (0, 0), (1, 1),
                                            pattern=[1.0], pattern_shape=(big, 1)),
                lambda: hetinv.Pathlength.bins(ctx, [1], 1, window=big),
                lambda: ms.layout(big),
                lambda: est.set_param(big, 1),
                lambda: pmap.entry(-1),
                lambda: pmap.entry(2**64),
                lambda: hetinv.ParamMap.identity(m, 2**32 + 2),
                lambda: hetinv.ParamMap.broadcast(m, big),
                lambda: opt.add_stage(pmap, iterations=big),
                lambda: opt.add_layerwise_stages(pmap, 1.0, big),
                lambda: opt.set_param("method", big),
                lambda: hetinv.NoiseModel(seed=-1),
                lambda: hetinv.MixtureSpec(components=big),
                lambda: hetinv.SmokeSpec(octaves=-big),
                lambda: hetinv.vol_write(ctx, "x.vol", [1.0], (big, 1, 1)),
                lambda: hetinv.vol_write(ctx, "x.vol", [1.0], (1, 1, 1), channels=big),
                lambda: hetinv.result_name(big),
            ]
            for i, call in enumerate(calls):
                print(i, end=" ")
                expect(OverflowError, call)
            assert pmap.entry(0) == (1, 0)
        """)

    def test_non_numbers_and_struct_sizes(self):
        self.assertChildOk("""
            expect(TypeError, m.clone().fill, "0.1", 1.0, 0.0)
            expect(TypeError, m.clone().set_voxel, 0.5, 0, 0, 0.1, 1.0, 0.0)
            expect(TypeError, est.set_param, "photons", "many")
            expect(TypeError, opt.set_bounds, "sigma_s", 1.0, None)
            expect(TypeError, hetinv.Pathlength.bins, ctx, [1], "wide")
            expect(TypeError, hetinv.Context, seed=1.5)
            expect(AttributeError, setattr, hetinv.NoiseModel(), "size", 10**6)
            expect(TypeError, hetinv.NoiseModel, read_noise="loud")
        """)


class Threads(ChildTest):
    """An estimator and an optimizer belong to one thread at a time: a call
    from a second thread while the first is in one is refused (two threads'
    passes on one estimator crashed the interpreter), and the owning thread
    may call in again (a progress callback rendering with the run's
    estimator)."""

    def test_a_second_thread_is_refused_while_the_first_renders(self):
        self.assertChildOk("""
            import threading
            big = hetinv.Medium(ctx, (0, 0, 0), (40, 40, 10), (40, 40, 10)).fill(0.1, 2.0, 0.5).commit()
            bs = hetinv.Measurements(ctx)
            bs.add(hetinv.Emitter.ideal(big, (20, 20, 10), (0, 0, -1)), hetinv.Sensor.hemispherical(big, "z_max"), p)
            bmap = hetinv.ParamMap.identity(big, hetinv.FREE_ALL)
            bs.set_values([0.5])
            slow = hetinv.Estimator(ctx, photons=200000)
            started, errors = threading.Event(), []
            def first():
                started.set()
                slow.loss_gradient(big, bs, bmap)
            t = threading.Thread(target=first)
            t.start()
            started.wait()
            import time
            for _ in range(200):  # until the first thread is inside its call
                try:
                    slow.loss_gradient(big, bs, bmap)
                except RuntimeError as x:
                    errors.append(str(x))
                    break
                time.sleep(0.001)
            t.join()
            print(errors[0] if errors else "no refusal")
            slow.render(big, bs)  # free again once the first call returned
        """, expect_in=["this hetinv.Estimator is in use by another thread: a hetinv.Estimator belongs to one thread at a time"])

    def test_the_owning_thread_may_call_in_again(self):
        self.assertChildOk("""
            opt.add_stage(pmap, iterations=2)
            seen = []
            def progress(pr):
                seen.append(len(est.render(m, ms).values))  # the run's own estimator, same thread
                opt.get_pi()
            opt.set_progress(progress)
            print(opt.run(est), seen)
        """, expect_in=["completed [1, 1]"])


class SetInUse(ChildTest):
    """A measurement set must not change while an optimizer made for it
    exists (hetinv_optimizer_create): its values, weights, mask and clip
    scales are refused as rows are, from a progress callback too."""

    def test_changes_are_refused_while_an_optimizer_exists(self):
        self.assertChildOk("""
            expect(RuntimeError, ms.set_values, [0.7])
            expect(RuntimeError, ms.set_weights, [2.0])
            expect(RuntimeError, ms.set_mask, [0])
            expect(RuntimeError, ms.set_clip_scales, [2.0])
            expect(RuntimeError, ms.mask_saturated, 0.1)
            opt.close()
            ms.set_values([0.7])  # free again
        """, expect_in=["raised RuntimeError cannot set the values of a measurement set an optimizer uses"])


class Paths(ChildTest):
    """A NUL byte would end the C string early: another file would be written."""

    def test_nul_in_a_path_is_refused(self):
        self.assertChildOk("""
            import os, tempfile
            d = tempfile.mkdtemp()
            target = os.path.join(d, "a.vol")
            expect(ValueError, m.write_vol, "sigma_s", target + "\\0.txt")
            expect(ValueError, hetinv.vol_write, ctx, target + "\\0.txt", [1.0], (1, 1, 1))
            expect(ValueError, opt.save, target + "\\0.txt")
            expect(ValueError, opt.set_checkpoint, target + "\\0.txt")
            assert not os.path.exists(target), "wrote " + target
            os.rmdir(d)
        """, expect_in=["embedded null byte"])


if __name__ == "__main__":
    unittest.main()
