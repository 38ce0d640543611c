"""Writes the channel and time-series fixtures of tests/channels.rs with reference writers
(tifffile, nibabel, pynrrd), each multi-frame file beside single frames of it written as plain
3-D files, and expected.json with every frame's sum and a few voxels.

    python3 -m venv /tmp/venv-ch && /tmp/venv-ch/bin/pip install tifffile numpy nibabel pynrrd
    /tmp/venv-ch/bin/python tests/data/channels/make.py
"""

import json
import os

import nibabel
import nrrd
import numpy
import tifffile

HERE = os.path.dirname(os.path.abspath(__file__))


def path(name):
    return os.path.join(HERE, name)


def pattern(shape, seed):
    """Smooth blobs plus a seed-dependent offset: every frame differs, values fit in u16."""
    rng = numpy.random.default_rng(seed)
    grids = numpy.meshgrid(*[numpy.arange(n) for n in shape], indexing="ij")
    value = numpy.zeros(shape)
    for _ in range(3):
        center = [rng.uniform(0, n) for n in shape]
        width = rng.uniform(2, 5)
        value += numpy.exp(-sum((g - c) ** 2 for g, c in zip(grids, center)) / (2 * width**2))
    return (value * 1000 + seed * 37).astype(numpy.uint16)


def frame_facts(frame_zyx):
    """Sum of a frame and its voxels at three (x, y, z) points."""
    z, y, x = frame_zyx.shape
    points = [(0, 0, 0), (x - 1, y // 2, z // 3), (x // 2, y - 1, z - 1)]
    return {
        "sum": int(frame_zyx.astype(numpy.int64).sum()),
        "voxels": [[px, py, pz, int(frame_zyx[pz, py, px])] for px, py, pz in points],
    }


expected = {"versions": {
    "tifffile": tifffile.__version__,
    "numpy": numpy.__version__,
    "nibabel": nibabel.__version__,
    "pynrrd": nrrd.__version__,
}}

# ImageJ hyperstack, T=2, Z=5, C=2: pages ordered c fastest, then z, then t (XYCZT).
T, Z, C, Y, X = 2, 5, 2, 12, 16
stack = numpy.stack([
    numpy.stack([pattern((Z, Y, X), 10 * t + c) for c in range(C)], axis=1)
    for t in range(T)
])  # TZCYX
# Channel 0's LUT black to cyan, channel 1's black to orange; each page labeled "name z t".
ramp = numpy.arange(256, dtype=numpy.uint8)
luts = [numpy.stack([0 * ramp, ramp, ramp]), numpy.stack([ramp, ramp // 2, 0 * ramp])]
labels = [f"{['nuclei', 'actin'][c]} z{z} t{t}" for t in range(T) for z in range(Z) for c in range(C)]
tifffile.imwrite(
    path("hyperstack.tif"), stack, imagej=True,
    resolution=(1 / 0.5, 1 / 0.5),
    metadata={"axes": "TZCYX", "spacing": 2.0, "unit": "um", "LUTs": luts, "Labels": labels},
)
# Channel 1 at time point 1 as a plain 3-D stack.
tifffile.imwrite(path("hyperstack-c1-t1.tif"), stack[1, :, 1], imagej=True,
                 resolution=(1 / 0.5, 1 / 0.5), metadata={"axes": "ZYX", "spacing": 2.0, "unit": "um"})
expected["hyperstack.tif"] = {
    "channels": C, "time_points": T, "dims": [X, Y, Z],
    "names": ["nuclei z0 t0", "actin z0 t0"], "colors": ["#00ffff", "#ff7f00"],
    "frames": {f"c{c}t{t}": frame_facts(stack[t, :, c]) for c in range(C) for t in range(T)},
}

# OME-TIFF, two named channels (CZYX: DimensionOrder XYZCT).
ome = numpy.stack([pattern((Z, Y, X), 100 + c) for c in range(2)])
tifffile.imwrite(
    path("two-channels.ome.tif"), ome,
    metadata={"axes": "CZYX", "Channel": {"Name": ["DAPI", "GFP"]},
              "PhysicalSizeX": 0.25, "PhysicalSizeY": 0.25, "PhysicalSizeZ": 1.0},
)
expected["two-channels.ome.tif"] = {
    "channels": 2, "time_points": 1, "dims": [X, Y, Z], "names": ["DAPI", "GFP"],
    "frames": {f"c{c}t0": frame_facts(ome[c]) for c in range(2)},
}

# RGB pages (samples interleaved): three channels.
rgb = numpy.stack([pattern((Z, Y, X), 200 + s) for s in range(3)], axis=-1).astype(numpy.uint8)
tifffile.imwrite(path("rgb.tif"), rgb, photometric="rgb")
expected["rgb.tif"] = {
    "channels": 3, "time_points": 1, "dims": [X, Y, Z],
    "frames": {f"c{s}t0": frame_facts(rgb[..., s]) for s in range(3)},
}

# 4-D NIfTI, three time points (dim[4]), int16, 1.5 x 1.5 x 2 mm.
NX, NY, NZ, NT = 10, 8, 6, 3
series = numpy.stack([pattern((NZ, NY, NX), 300 + t).astype(numpy.int16) for t in range(NT)])
affine = numpy.diag([1.5, 1.5, 2.0, 1.0])
# nibabel wants x fastest in memory order (x, y, z, t) axes.
xyzt = numpy.transpose(series, (3, 2, 1, 0))
nibabel.save(nibabel.Nifti1Image(xyzt, affine), path("series-4d.nii.gz"))
nibabel.save(nibabel.Nifti1Image(xyzt, affine), path("series-4d.nii"))
nibabel.save(nibabel.Nifti1Image(numpy.ascontiguousarray(xyzt[..., 1]), affine),
             path("series-t1.nii.gz"))
expected["series-4d.nii.gz"] = {
    "channels": 1, "time_points": NT, "dims": [NX, NY, NZ],
    "frames": {f"c0t{t}": frame_facts(series[t]) for t in range(NT)},
}

# NRRD with an interleaved channel axis first (kinds: vector domain domain domain).
vector = numpy.stack([pattern((NZ, NY, NX), 400 + c).astype(numpy.float32) for c in range(3)])
# pynrrd writes in Fortran order by default: index order (c, x, y, z), c fastest.
cxyz = numpy.transpose(vector, (0, 3, 2, 1))
nrrd.write(path("vector.nrrd"), cxyz, header={
    "kinds": ["vector", "domain", "domain", "domain"],
    "space": "right-anterior-superior",
    "space directions": numpy.array([[numpy.nan] * 3, [0.5, 0, 0], [0, 0.5, 0], [0, 0, 0.5]]),
    "encoding": "gzip",
})
expected["vector.nrrd"] = {
    "channels": 3, "time_points": 1, "dims": [NX, NY, NZ],
    "frames": {f"c{c}t0": frame_facts(vector[c]) for c in range(3)},
}

with open(path("expected.json"), "w") as out:
    json.dump(expected, out, indent=1)
    out.write("\n")
