"""Checks that ome-zarr-py reads what `voxscope convert` writes (run at development time; CI
does not install Python packages).

    /tmp/zpy/bin/python tests/data/ome-zarr/check_convert.py target/debug/voxscope

Writes a raw u16 volume with numpy, converts it with every --format and --compression, opens
each result with ome-zarr-py's reader (the library napari-ome-zarr uses), and compares every
level with numpy's own 2x mean pyramid (make_fixtures.mean_down) and the axes and scales with
what convert promises. Prints one line per case; exits non-zero on the first difference.
"""

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from ome_zarr.io import parse_url
from ome_zarr.reader import Multiscales, Reader

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_fixtures import mean_down  # noqa: E402


def main(binary):
    rng = np.random.default_rng(7)
    z, y, x = 45, 70, 90
    volume = (rng.normal(1000, 300, (z, y, x)).clip(0, 65535)).astype(np.uint16)
    volume[:, :, :20] = 0
    with tempfile.TemporaryDirectory() as tmp:
        raw = Path(tmp) / "v.raw"
        volume.tofile(raw)
        for fmt in ("0.4", "0.5"):
            for compression in ("blosc-lz4", "blosc-zstd", "zstd", "gzip", "none"):
                out = Path(tmp) / f"v-{fmt}-{compression}.ome.zarr"
                subprocess.run(
                    [binary, "convert", str(raw), str(out), "--raw", f"{x}x{y}x{z}:u16",
                     "--spacing", "0.5,0.5,2", "--unit", "micrometer", "--chunk", "16",
                     "--format", fmt, "--compression", compression],
                    check=True, capture_output=True,
                )
                nodes = list(Reader(parse_url(str(out)))())
                image = nodes[0]
                assert any(isinstance(spec, Multiscales) for spec in image.specs), image.specs
                levels = image.data
                expected = volume
                for index, level in enumerate(levels):
                    got = np.asarray(level)
                    assert got.shape == expected.shape, (index, got.shape, expected.shape)
                    assert np.array_equal(got, expected), f"{fmt} {compression} level {index} differs"
                    expected = mean_down(expected)
                multiscale = image.metadata
                axes = [a["name"] for a in multiscale["axes"]]
                assert axes == ["z", "y", "x"], axes
                assert multiscale["axes"][2]["unit"] == "micrometer"
                scale = multiscale["coordinateTransformations"][1][0]["scale"]
                assert scale == [4.0, 1.0, 1.0], scale
                print(f"ok {fmt} {compression}: {len(levels)} levels {[tuple(np.asarray(l).shape) for l in levels]}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "target/debug/voxscope")
