"""The paper's Fig. 4(a) as a figure: truth, recovery and relative error of
σa, σs and g over a reconstructed cross-section, and a transient stack of
the truth volume shown as frames.

    python3 fig4a_figure.py RESULT_DIR [--out fig4a.png] [--transient transient.png]
                            [--eta 1.3] [--photons N] [--title TEXT]

RESULT_DIR is an output folder of hetinv-reconstruct (or hetinv-fig4):
it reads truth_<param>.vol and recovered_<param>.vol there, and writes
RESULT_DIR/fig4a.png and RESULT_DIR/transient.png unless told otherwise.
Where the folder holds the bound (bound.exr), a fourth column sets each
voxel's error against it: the error in units of the relative standard
deviation the data allow an unbiased recovery (the full bound where the
estimated Fisher matrix is positive definite, else the local one; gray
where neither determines the voxel).
The transient stack is rendered here from the truth volume: a pencil beam
at the middle of the top face (z max), an orthographic camera on the
section's face (y max), pathlength bins of one voxel's width. --eta is the volume's refractive
index (a .vol file does not store it; hetinv-reconstruct's built-in scene
uses 1.3).

Needs numpy and matplotlib (Debian: python3-numpy python3-matplotlib) and
the library: HETINV_LIBRARY=/path/to/libhetinv.so if it is not installed,
PYTHONPATH=bindings/python if the package is not.
"""
import argparse
import os

import matplotlib

matplotlib.use("Agg")  # files only, no display needed
import matplotlib.colors  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import hetinv  # noqa: E402

PARAMS = (("sigma_a", "σa", "mm⁻¹"), ("sigma_s", "σs", "mm⁻¹"), ("g", "g", "(unitless)"))


def read_section(ctx, path):
    """A .vol file as a (z, x) array (the section's rows are depth), with its header."""
    header, data = hetinv.vol_read(ctx, path)
    nx, ny, nz = header.dims
    if header.channels != 1:
        raise SystemExit("%s: %d channels, expected 1" % (path, header.channels))
    grid = np.asarray(data, dtype=np.float64).reshape(nz, ny, nx)
    return header, grid[:, ny // 2, :]


def extent(header):
    """imshow extent in mm: x across, z up."""
    return (header.box_min[0], header.box_max[0], header.box_min[2], header.box_max[2])


def read_bound(ctx, folder):
    """bound.exr's image (row = z, as the section), or None without one."""
    path = os.path.join(folder, "bound.exr")
    return hetinv.read_exr(ctx, path) if os.path.exists(path) else None


def bound_section(bound, name):
    """The relative standard deviation per voxel: the full bound where it
    exists (F̂ positive definite), else the local one."""
    full = np.asarray(bound["bound_%s" % name], dtype=np.float64)
    if "bound_local_%s" % name not in bound.channel_names:  # F̂ positive definite: no local bound
        return full
    local = np.asarray(bound["bound_local_%s" % name], dtype=np.float64)
    return np.where(np.isfinite(full), full, local)


def draw_maps(ctx, folder, out, title=None):
    bound = read_bound(ctx, folder)
    cols = 3 if bound is None else 4
    fig, axes = plt.subplots(3, cols, figsize=(3.5 * cols, 9.0), constrained_layout=True)
    summary = []
    for row, (name, symbol, unit) in enumerate(PARAMS):
        header, truth = read_section(ctx, os.path.join(folder, "truth_%s.vol" % name))
        _, rec = read_section(ctx, os.path.join(folder, "recovered_%s.vol" % name))
        rel = np.abs(rec - truth) / np.abs(truth)
        lo, hi = float(min(truth.min(), rec.min())), float(max(truth.max(), rec.max()))
        ext = extent(header)
        # Truth and recovery share one colour scale, so they can be compared by eye.
        for col, (img, what) in enumerate(((truth, "truth"), (rec, "recovery"))):
            ax = axes[row, col]
            im = ax.imshow(img, origin="lower", extent=ext, vmin=lo, vmax=hi, cmap="viridis")
            ax.set_title("%s %s" % (symbol, what))
            fig.colorbar(im, ax=ax, label="%s [%s]" % (symbol, unit))
        ax = axes[row, 2]
        im = ax.imshow(100.0 * rel, origin="lower", extent=ext, vmin=0.0, vmax=max(15.0, 100.0 * rel.max()),
                       cmap="magma")
        ax.set_title("%s relative error\nmean %.1f %%, max %.1f %%" % (symbol, 100 * rel.mean(), 100 * rel.max()))
        fig.colorbar(im, ax=ax, label="|recovery − truth| / truth [%]")
        in_bounds = None
        if bound is not None:
            z = rel / bound_section(bound, name)
            known = np.isfinite(z)
            in_bounds = float(z[known].max()) if known.any() else float("nan")
            ax = axes[row, 3]
            cmap = matplotlib.colormaps["magma"].with_extremes(bad="0.6")  # gray: no bound
            im = ax.imshow(np.ma.masked_invalid(z), origin="lower", extent=ext, vmin=0.0,
                           vmax=max(3.0, in_bounds if known.any() else 0.0), cmap=cmap)
            over, undetermined = int(np.count_nonzero(z[known] > 2.0)), int(np.count_nonzero(~known))
            ax.set_title("%s error ÷ bound: max %.1f\n%d of %d voxels over 2%s"
                         % (symbol, in_bounds, over, z.size,
                            ", %d undetermined (gray)" % undetermined if undetermined else ""))
            fig.colorbar(im, ax=ax, label="error / bound")
        summary.append((name, rel.mean(), rel.max(), in_bounds))
        for ax in axes[row]:
            ax.set_xlabel("x [mm]")
            ax.set_ylabel("z [mm]")
    fig.suptitle(title or "Heterogeneous inverse scattering: %s" % os.path.basename(os.path.abspath(folder)))
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return summary


def draw_transient(ctx, folder, out, eta, photons):
    """Frames of a pathlength-resolved image of the truth under a pencil beam."""
    header, _ = read_section(ctx, os.path.join(folder, "truth_sigma_a.vol"))
    nx, ny, nz = header.dims
    box_min, box_max = list(header.box_min), list(header.box_max)
    medium = hetinv.Medium(ctx, box_min, box_max, (nx, ny, nz)).set_ior(eta, 1.0)
    for name, _, _ in PARAMS:
        medium.read_vol(name, os.path.join(folder, "truth_%s.vol" % name))
    medium.commit()
    voxel = (box_max[0] - box_min[0]) / nx
    frames, sub = 8, 4  # pathlength bins of one voxel's width; 4 × 4 pixels per voxel
    # No path to the section face is shorter than the beam's distance to it.
    first = 0.5 * (box_max[1] - box_min[1])
    centres = [first + voxel * (k + 0.5) for k in range(frames)]
    bins = hetinv.Pathlength.bins(ctx, centres, voxel)
    middle = (0.5 * (box_min[0] + box_max[0]), 0.5 * (box_min[1] + box_max[1]))
    beam = hetinv.Emitter.ideal(medium, (middle[0], middle[1], box_max[2] + 1.0), (0.0, 0.0, -1.0))
    # The camera faces the section (the y_max face, face coordinates (x, z)):
    # each frame is the section as light leaves it after path length τ.
    w, h = nx * sub, nz * sub
    camera = hetinv.Sensor.orthographic(medium, "y_max", (0.0, 1.0, 0.0), (box_min[0], box_min[2]),
                                        (voxel / sub, (box_max[2] - box_min[2]) / h), w, h)
    rows = hetinv.Measurements(ctx)
    rows.add(beam, camera, bins)
    est = hetinv.Estimator(ctx, photons=photons)
    values = np.asarray(est.render(medium, rows).values).reshape(frames, h, w)
    fig, axes = plt.subplots(1, frames, figsize=(1.9 * frames, 2.9), constrained_layout=True)
    vmax = float(values.max()) if values.max() > 0 else 1.0
    # A logarithmic scale: late frames are orders of magnitude darker.
    norm = matplotlib.colors.LogNorm(vmin=vmax * 1e-4, vmax=vmax)
    ext = extent(header)
    for k, ax in enumerate(axes):
        im = ax.imshow(np.maximum(values[k], vmax * 1e-4), origin="lower", extent=ext, norm=norm, cmap="inferno")
        ax.set_title("τ = %.2f mm" % centres[k], fontsize=9)
        ax.set_xlabel("x [mm]")
        if k == 0:
            ax.set_ylabel("z [mm]")
        else:
            ax.set_yticks([])
    fig.colorbar(im, ax=list(axes), label="radiance per unit power, per bin")
    fig.suptitle("Transient stack of the truth seen on its section face: a pencil beam enters at the top")
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", help="an output folder of hetinv-reconstruct")
    parser.add_argument("--out", help="figure of the maps (default FOLDER/fig4a.png)")
    parser.add_argument("--transient", help="figure of the transient frames (default FOLDER/transient.png)")
    parser.add_argument("--eta", type=float, default=1.3, help="refractive index of the volume (default 1.3)")
    parser.add_argument("--photons", type=int, default=200000, help="photons of the transient render")
    parser.add_argument("--title", help="title of the maps (default: the folder's name)")
    args = parser.parse_args()
    ctx = hetinv.Context(seed=2016, threads=0)
    out = args.out or os.path.join(args.folder, "fig4a.png")
    for name, mean, worst, in_bounds in draw_maps(ctx, args.folder, out, args.title):
        against = "" if in_bounds is None else "  worst error ÷ bound %.2f" % in_bounds
        print("%-8s mean %.2f %%  max %.2f %%%s" % (name, 100 * mean, 100 * worst, against))
    print("wrote", out)
    transient = args.transient or os.path.join(args.folder, "transient.png")
    draw_transient(ctx, args.folder, transient, args.eta, args.photons)
    print("wrote", transient)


if __name__ == "__main__":
    main()
