"""Shared by the Python binding tests: the scene c_reference.c builds, built
through the binding, and a reader of the C program's "%a" output."""
import os
import struct
import subprocess
import sys

import hetinv

BOX_MIN, BOX_MAX, DIMS = (0, 0, 0), (4, 4, 1), (4, 4, 1)


def truth_medium(ctx):
    m = hetinv.Medium(ctx, BOX_MIN, BOX_MAX, DIMS).set_ior(1.3, 1.0).fill(0.1, 5.0, 0.5)
    m.set_voxel(1, 1, 0, 0.1, 8.0, 0.5)
    m.set_voxel(2, 2, 0, 0.2, 3.0, 0.5)
    return m.commit()


def initial_medium(ctx):
    return hetinv.Medium(ctx, BOX_MIN, BOX_MAX, DIMS).set_ior(1.3, 1.0).fill(0.1, 5.0, 0.5).commit()


def measurement_set(ctx, medium):
    """Two beams and a diffuse source; a camera on top, a detector below."""
    emitters = [hetinv.Emitter.ideal(medium, (1, 4.5, 0.5), (0, -1, 0)),
                hetinv.Emitter.ideal(medium, (3, 4.5, 0.5), (0, -1, 0)),
                hetinv.Emitter.diffuse(medium, "y_min", (2, 0.5))]
    cam = hetinv.Sensor.orthographic(medium, "y_max", (0, 1, 0), (0, 0), (1, 1), 4, 1)
    below = hetinv.Sensor.hemispherical(medium, hetinv.FACE_Y_MIN)
    steady = hetinv.Pathlength.steady(ctx)
    bins = hetinv.Pathlength.bins(ctx, [2, 6, 10], 4, window="box")
    ms = hetinv.Measurements(ctx)
    for e in emitters:
        ms.add(e, cam, steady)
        ms.add(e, below, steady)
    ms.add(emitters[0], cam, bins)
    return ms


def c_reference():
    """{key: [floats]} and {struct: size} printed by tests/python/c_reference."""
    exe = os.environ.get("HETINV_C_REFERENCE")
    if not exe:
        raise RuntimeError("HETINV_C_REFERENCE is not set (run through ctest)")
    text = subprocess.run([exe], check=True, stdout=subprocess.PIPE, universal_newlines=True).stdout
    values, sizes = {}, {}
    for line in text.splitlines():
        key, index, value = line.split()
        if key == "sizeof":
            sizes[index] = int(value)
        else:
            values.setdefault(key, []).append(float.fromhex(value))
            assert len(values[key]) == int(index) + 1
    return values, sizes


def bits(values):
    """The exact bytes of a sequence of doubles, for bitwise comparison."""
    values = list(hetinv.flat(values))  # numpy grids and π are shaped; bits in C order
    return struct.pack("<%dd" % len(values), *values)


def hexes(values):
    return [float(v).hex() for v in values]


sys.dont_write_bytecode = True
