"""Writes the HCS plate fixture with the reference implementation (ome-zarr-py).

Run from the repository root:

    python3 -m venv /tmp/zpy && /tmp/zpy/bin/pip install ome-zarr zarr numpy
    /tmp/zpy/bin/python tests/data/plates/make_fixtures.py

`plate-v04.ome.zarr`: an OME-Zarr 0.4 plate of rows A, B and columns 1, 2, 3 with two wells
(A/1 and B/3), each of two fields (0 and 1); every field one level of 8 x 6 x 4 voxels (x y z,
u8), its voxels (z, y, x) = 10 * well + 4 * field + (x + y + z) % 4, well 0 = A/1, 1 = B/3,
so each field's values say which field it is. expected.json records the versions and each
field's voxel sum.
"""

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import ome_zarr
import zarr
from ome_zarr.format import FormatV04
from ome_zarr.writer import write_image, write_plate_metadata, write_well_metadata

HERE = Path(__file__).resolve().parent
SHAPE = (4, 6, 8)  # z, y, x
WELLS = ["A/1", "B/3"]
FIELDS = ["0", "1"]


def field_voxels(well: int, field: int) -> np.ndarray:
    z, y, x = np.indices(SHAPE)
    return (10 * well + 4 * field + (x + y + z) % 4).astype(np.uint8)


def main() -> None:
    path = HERE / "plate-v04.ome.zarr"
    shutil.rmtree(path, ignore_errors=True)
    fmt = FormatV04()
    root = zarr.open_group(str(path), mode="w", zarr_format=2)
    write_plate_metadata(root, ["A", "B"], ["1", "2", "3"], WELLS, fmt=fmt, field_count=len(FIELDS), name="tiny plate")
    sums = {}
    for w, well_path in enumerate(WELLS):
        row, column = well_path.split("/")
        well = root.require_group(row).require_group(column)
        write_well_metadata(well, FIELDS, fmt=fmt)
        for f, field in enumerate(FIELDS):
            image = well.require_group(field)
            data = field_voxels(w, f)
            write_image(data, image, scale_factors=[], axes="zyx", fmt=fmt)
            sums[f"{well_path}/{field}"] = int(data.astype(np.int64).sum())
    versions = {
        "ome-zarr": ome_zarr.__version__,
        "zarr": zarr.__version__,
        "numpy": np.__version__,
        "python": sys.version.split()[0],
    }
    (HERE / "expected.json").write_text(json.dumps({"versions": versions, "field_sums": sums}, indent=1) + "\n")


if __name__ == "__main__":
    main()
