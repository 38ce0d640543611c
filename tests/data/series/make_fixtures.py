"""Writes the bioformats2raw fixture (a root with two series) with zarr-python and ome-zarr-py.

Run from the repository root:

    python3 -m venv /tmp/b2r-venv && /tmp/b2r-venv/bin/pip install ome-zarr zarr numpy
    /tmp/b2r-venv/bin/python tests/data/series/make_fixtures.py

`two-series.zarr`: the layout bioformats2raw writes (version 3): a root group with the
attribute "bioformats2raw.layout": 3, image groups 0 and 1 (each an OME-Zarr 0.4 multiscales
image written by ome-zarr-py's write_image, one level) and a group OME whose "series" attribute
lists them, beside OME/METADATA.ome.xml naming each image. Series 0 is 8 x 6 x 4 voxels (x y z,
u8), (z, y, x) = (x + y + z) % 4; series 1 is 5 x 4 x 3 voxels (u16), (z, y, x) = 1000 + 100 z +
10 y + x, so every voxel of series 1 says where it is. expected.json records the versions, each
series' name, shape and voxel sum.
"""

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import ome_zarr
import zarr
from ome_zarr.format import FormatV04
from ome_zarr.writer import write_image

HERE = Path(__file__).resolve().parent
NAMES = ["first image", "second image"]


def series_voxels(index: int) -> np.ndarray:
    if index == 0:
        z, y, x = np.indices((4, 6, 8))
        return ((x + y + z) % 4).astype(np.uint8)
    z, y, x = np.indices((3, 4, 5))
    return (1000 + 100 * z + 10 * y + x).astype(np.uint16)


OME_XML = """<?xml version="1.0" encoding="UTF-8"?>
<OME xmlns="http://www.openmicroscopy.org/Schemas/OME/2016-06">
{images}
</OME>
"""

IMAGE = """  <Image ID="Image:{index}" Name="{name}">
    <Pixels ID="Pixels:{index}" DimensionOrder="XYZCT" Type="{type}" SizeX="{x}" SizeY="{y}" SizeZ="{z}" SizeC="1" SizeT="1">
      <Channel ID="Channel:{index}:0" SamplesPerPixel="1"/>
    </Pixels>
  </Image>"""


def main() -> None:
    path = HERE / "two-series.zarr"
    shutil.rmtree(path, ignore_errors=True)
    fmt = FormatV04()
    root = zarr.open_group(str(path), mode="w", zarr_format=2)
    root.attrs["bioformats2raw.layout"] = 3
    series = {}
    images = []
    for index, name in enumerate(NAMES):
        data = series_voxels(index)
        write_image(data, root.require_group(str(index)), scale_factors=[], axes="zyx", fmt=fmt)
        z, y, x = data.shape
        series[str(index)] = {"name": name, "dims": [x, y, z], "sum": int(data.astype(np.int64).sum())}
        images.append(IMAGE.format(index=index, name=name, type=str(data.dtype), x=x, y=y, z=z))
    ome = root.require_group("OME")
    ome.attrs["series"] = [str(i) for i in range(len(NAMES))]
    (path / "OME" / "METADATA.ome.xml").write_text(OME_XML.format(images="\n".join(images)))
    versions = {
        "ome-zarr": ome_zarr.__version__,
        "zarr": zarr.__version__,
        "numpy": np.__version__,
        "python": sys.version.split()[0],
    }
    (HERE / "expected.json").write_text(json.dumps({"versions": versions, "series": series}, indent=1) + "\n")


if __name__ == "__main__":
    main()
