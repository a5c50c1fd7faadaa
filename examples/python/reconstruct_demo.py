"""Reconstruct the scattering coefficient of a 2D cross-section from noisy
boundary measurements, with libhetinv's Python binding.

A notebook-style script: each `# %%` cell can be run on its own in an
editor that understands cells (VS Code, Spyder, Jupyter's py:percent), or
the whole file with `python3 reconstruct_demo.py [--quick] [--out DIR]`.
--quick shrinks everything so it runs in seconds (the test suite uses it).
Needs the library: set HETINV_LIBRARY=/path/to/libhetinv.so if it is not
installed, and PYTHONPATH=bindings/python if the package is not.
"""
# %% [markdown]
# ## Set-up
# The scene is a 10 mm cube seen as a 2D cross-section: n × n voxels in x
# and y, one voxel along z (the grid is constant along z). Everything is
# seeded, so two runs print the same numbers.
import argparse
import math
import os

import hetinv

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--quick", action="store_true", help="tiny problem, a few seconds")
parser.add_argument("--out", default="out/python-demo", help="folder for the result .vol files")
args, _ = parser.parse_known_args()

n = 4 if args.quick else 12                 # voxels per side
photons = 500 if args.quick else 20000      # per emitter and render
iterations = (3, 3) if args.quick else (40, 60)
beams = 3 if args.quick else 8
os.makedirs(args.out, exist_ok=True)

ctx = hetinv.Context(seed=2016, threads=0)
box_min, box_max, dims = (0, 0, 0), (10, 10, 10), (n, n, 1)

# %% [markdown]
# ## The medium to recover
# σs is a random mixture of two Gaussian blobs between 2 and 8 mm⁻¹ (as in
# Fig. 4 of the paper); σa and g are known and constant.
truth = hetinv.Medium(ctx, box_min, box_max, dims).set_ior(1.3, 1.0)
truth.fill_gaussian_mixture(seed=4, constant_axis=2, lo=(0.05, 2.0, 0.5), hi=(0.05, 8.0, 0.5))
truth.commit()
sigma_true = list(hetinv.flat(truth.grid("sigma_s")))  # grids are (nz, ny, nx) with numpy
print("true sigma_s in [%.2f, %.2f] /mm" % (min(sigma_true), max(sigma_true)))

# %% [markdown]
# ## Measurements
# Pencil beams enter through the top face (y = 10) at several x positions;
# an orthographic camera looks down at the top face (backscatter) and a
# detector collects what leaves through the bottom (transmission).
camera = hetinv.Sensor.orthographic(truth, "y_max", (0, 1, 0), (0, 0), (10.0 / n, 10), n, 1)
below = hetinv.Sensor.hemispherical(truth, "y_min")
measurements = hetinv.Measurements(ctx)
for i in range(beams):
    x = 10.0 * (i + 0.5) / beams
    beam = hetinv.Emitter.ideal(truth, (x, 10.5, 5.0), (0, -1, 0))
    measurements.add(beam, camera)
    measurements.add(beam, below)
print("%d emitters, %d values" % (beams, measurements.value_count))

# %% [markdown]
# ## Simulated acquisition
# Render the clean values, then add the Hasinoff affine noise of a camera
# (Poisson photon noise, read noise, automatic exposure). The noise model's
# standard errors become the loss weights 1/σ².
estimator = hetinv.Estimator(ctx, photons=photons)
clean = estimator.render(truth, measurements).values
noisy = hetinv.apply_noise(ctx, clean, seed=1, read_noise=5.0)
measurements.set_values(noisy.values, noisy.std_errors)
scale = max(clean)
measurements.set_weights([1.0 / max(e, 1e-3 * scale) ** 2 for e in noisy.std_errors])
print("exposure %.4g electrons per unit" % noisy.exposure)

# %% [markdown]
# ## Reconstruction, coarse to fine
# Start from a homogeneous guess (the mean of the range) and let ADADELTA
# fit σs on a half-resolution grid first, then per voxel.
initial = truth.clone()
initial.set_grid("sigma_s", [5.0] * truth.voxel_count)
initial.commit()

coarse = hetinv.ParamMap.coarse(truth, (max(1, n // 2), max(1, n // 2), 1), "sigma_s")
fine = hetinv.ParamMap.identity(truth, "sigma_s")
optimizer = hetinv.Optimizer(ctx, measurements, initial, method="adadelta", average_window=5)
optimizer.set_bounds("sigma_s", 1.0, 10.0)
optimizer.add_stage(coarse, iterations=iterations[0])
optimizer.add_stage(fine, iterations=iterations[1])


def report(p):
    if p.stage_iteration == 1 or p.stage_iteration == p.stage_iterations:
        print("  stage %d/%d, iteration %3d: loss %.4g" % (p.stage + 1, p.stage_count,
                                                          p.iteration, p.loss))


optimizer.set_progress(report)
print("stopped:", optimizer.run(estimator))

# %% [markdown]
# ## Results
# The relative error ‖σs − σs_true‖ / ‖σs_true‖ of the initial guess and of
# the estimate, and the estimate as a Mitsuba .vol file.
def relative_error(values):
    num = math.sqrt(sum((v - t) ** 2 for v, t in zip(hetinv.flat(values), sigma_true)))
    return num / math.sqrt(sum(t * t for t in sigma_true))


result = optimizer.result()
print("relative error of sigma_s: initial %.3f, estimate %.3f"
      % (relative_error(initial.grid("sigma_s")), relative_error(result.grid("sigma_s"))))
path = os.path.join(args.out, "sigma_s_estimate.vol")
result.write_vol("sigma_s", path)
truth.write_vol("sigma_s", os.path.join(args.out, "sigma_s_true.vol"))
print("wrote", path)
ctx.close()  # closes everything made from it
