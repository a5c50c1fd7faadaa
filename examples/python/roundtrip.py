"""The whole round trip with numpy: a truth medium, noisy measurements of it,
written to disk and read back, a reconstruction, and truth and recovery
compared as grid-shaped arrays.

    python3 roundtrip.py [--quick] [--out DIR]

--quick shrinks everything so it runs in seconds (the test suite uses it).
The part between the README markers is bindings/python/README.md's example
verbatim (the test python_readme_roundtrip checks it). DIR then holds
truth_<param>.vol and recovered_<param>.vol, which
examples/python/fig4a_figure.py DIR draws as the paper's Fig. 4(a).
Needs numpy (Debian: python3-numpy) and the library (installed, or
HETINV_LIBRARY=/path/to/libhetinv.so; PYTHONPATH=bindings/python if the
package is not installed).
"""
import argparse
import sys

try:
    import numpy  # noqa: F401
except ImportError:
    print("SKIPPED: this example needs numpy (Debian: apt-get install python3-numpy)")
    sys.exit(77)

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--quick", action="store_true", help="tiny problem, a few seconds")
parser.add_argument("--out", default="out/roundtrip", help="folder for the files written")
args = parser.parse_args()
quick, out = args.quick, args.out

# --- README begin ---
import os

import numpy as np

import hetinv

n = 4 if quick else 8                       # voxels along x and z (one along y)
photons = 500 if quick else 2000            # per beam and render while reconstructing
iterations = (3, 3) if quick else (40, 80)  # coarse stage, fine stage
beams = 2 if quick else 4                   # per face
os.makedirs(out, exist_ok=True)
ctx = hetinv.Context(seed=2016, threads=0)  # seeded: the same numbers every run

# 1. The truth: a 1 mm x-z cross-section, sigma_s a random mixture of
#    Gaussian blobs in [2, 8] /mm, constant along y; sigma_a and g known.
truth = hetinv.Medium(ctx, (0, 0, 0), (1, 1, 1), (n, 1, n)).set_ior(1.3, 1.0)
truth.fill_gaussian_mixture(seed=4, constant_axis=1, lo=(0.05, 2.0, 0.5), hi=(0.05, 8.0, 0.5))
truth.commit()
sigma_true = truth.grid("sigma_s")          # shape (nz, ny, nx) = (n, 1, n): [iz, iy, ix]

# 2. Noisy measurements: pencil beams into the top face (z max) and the
#    left face (x min), each seen by a camera of n x n pixels on the
#    section's face (y max). The truth is rendered with 10x the photons.
camera = hetinv.Sensor.orthographic(truth, "y_max", (0, 1, 0), (0, 0), (1 / n, 1 / n), n, n)
measurements = hetinv.Measurements(ctx)
for t in (np.arange(beams) + 0.5) / beams:
    measurements.add(hetinv.Emitter.ideal(truth, (t, 0.5, 1.05), (0, 0, -1)), camera)
    measurements.add(hetinv.Emitter.ideal(truth, (-0.05, 0.5, t), (1, 0, 0)), camera)
clean = hetinv.Estimator(ctx, photons=10 * photons).render(truth, measurements)
print("row 0 is an image of shape", clean.row(0).shape)     # (bins, height, width)
noisy = hetinv.apply_noise(ctx, clean.values, seed=1, read_noise=5.0)

# 3. Write them (one image per beam) and the truth, then read them back.
rows = range(measurements.row_count)
np.savez(os.path.join(out, "measurements.npz"),
         values=np.stack([measurements.row(noisy.values, r) for r in rows]),
         std_errors=np.stack([measurements.row(noisy.std_errors, r) for r in rows]))
for p in ("sigma_a", "sigma_s", "g"):
    truth.write_vol(p, os.path.join(out, "truth_%s.vol" % p))
data = np.load(os.path.join(out, "measurements.npz"))
values, errors = data["values"], data["std_errors"]           # (rows, 1, n, n) each
measurements.set_values(values, errors)                       # any shape, read in C order
measurements.set_weights(1.0 / np.maximum(errors, 1e-3 * values.max()) ** 2)

# 4. Reconstruct sigma_s from a homogeneous guess: ADADELTA on a half
#    resolution grid, then per voxel; gradients come shaped like the map.
initial = truth.clone().set_grid("sigma_s", np.full(truth.shape, 5.0)).commit()
coarse = hetinv.ParamMap.coarse(truth, (max(1, n // 2), 1, max(1, n // 2)), "sigma_s")
fine = hetinv.ParamMap.identity(truth, "sigma_s")
estimator = hetinv.Estimator(ctx, photons=photons)
lg = estimator.loss_gradient(initial, measurements, fine)
print("loss %.4g at the guess; dloss/dsigma_s has shape %s" % (lg.loss, lg.grad.shape))
optimizer = hetinv.Optimizer(ctx, measurements, initial, method="adadelta", epsilon=0.003,
                             average_window=10)
optimizer.set_bounds("sigma_s", 1.0, 10.0)
optimizer.add_stage(coarse, iterations=iterations[0])
optimizer.add_stage(fine, iterations=iterations[1])
print("stopped:", optimizer.run(estimator), "after", len(optimizer.losses()), "iterations")
recovered = optimizer.result()

# 5. Compare truth and recovery voxel by voxel, as (nz, ny, nx) arrays.
sigma_rec = recovered.grid("sigma_s")
rel = np.abs(sigma_rec - sigma_true) / sigma_true
norm = np.linalg.norm
print("relative error of sigma_s: guess %.3f, recovery %.3f (per voxel: mean %.3f, max %.3f)"
      % (norm(initial.grid("sigma_s") - sigma_true) / norm(sigma_true),
         norm(sigma_rec - sigma_true) / norm(sigma_true), rel.mean(), rel.max()))
print("worst voxel (iz, iy, ix):", np.unravel_index(np.argmax(rel), rel.shape))
for p in ("sigma_a", "sigma_s", "g"):
    recovered.write_vol(p, os.path.join(out, "recovered_%s.vol" % p))
print("wrote", out, "(figure: python3 examples/python/fig4a_figure.py %s)" % out)
ctx.close()  # closes everything made from it
# --- README end ---
