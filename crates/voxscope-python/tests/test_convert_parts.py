"""`voxscope.convert.plan`, `run_part` and `finalize`: the conversion's parts run in separate
worker processes (as Dask's or Ray's workers run them), in any order, write the bytes of the
one-process `convert`, and zarr-python reads the voxels written; so does the Dask script of
docs/cluster.md on a LocalCluster."""

import multiprocessing
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import zarr

import voxscope

from conftest import REPO, shared_data


def image_files(root: Path) -> dict:
    """Every file of the image (not the plan's folder), by path, with its bytes."""
    return {
        p.relative_to(root): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file() and ".voxscope" not in p.relative_to(root).parts
    }


def run_part(args):
    plan, part = args
    return voxscope.convert.run_part(plan, part)


def test_parts_in_worker_processes_write_the_one_process_bytes(tmp_path):
    # The confocal nuclei (60x256x256 u16), tiled to 768x768x120 so that it cuts into columns.
    nuclei = shared_data("nuclei-60x256x256.tif")
    options = dict(format="0.5", chunk=32, shard=2, tile="3,3,2")
    whole = tmp_path / "whole.ome.zarr"
    levels = voxscope.convert(nuclei, whole, **options)
    plan = voxscope.convert.plan(nuclei, tmp_path / "parts.ome.zarr", parts=3, **options)
    assert plan == str(tmp_path / "parts.ome.zarr")
    context = multiprocessing.get_context("spawn")
    with context.Pool(3) as pool:
        figures = pool.map(run_part, [(plan, part) for part in (2, 0, 1)])
    assert [f["part"] for f in figures] == [2, 0, 1]
    assert all(f["parts"] == 3 and f["objects"] > 0 and not f["already_done"] for f in figures)
    assert sum(f["bytes_in"] for f in figures) == 768 * 768 * 120 * 2
    assert voxscope.convert.run_part(plan, 1)["already_done"]
    assert voxscope.convert.finalize(plan) == levels
    assert image_files(Path(plan)) == image_files(whole)

    # zarr-python reads the voxels written: level 0 is the tiled stack.
    group = zarr.open_group(plan, mode="r")
    stack = voxscope.open(nuclei).read()
    assert np.array_equal(group["0"][:], np.tile(stack, (2, 3, 3)))
    window = group.attrs["ome"]["omero"]["channels"][0]["window"]
    assert window["min"] == stack.min() and window["max"] == stack.max()
    assert window["min"] <= window["start"] < window["end"] <= window["max"]


def test_a_missing_part_is_named(tmp_path):
    nuclei = shared_data("nuclei-60x256x256.tif")
    plan = voxscope.convert.plan(nuclei, tmp_path / "out.ome.zarr", parts=2, chunk=32, tile="3,3,1")
    voxscope.convert.run_part(plan, 0)
    with pytest.raises(voxscope.LoadError, match=r"part 1 of 2 not finished.*--part 1/2"):
        voxscope.convert.finalize(plan)
    with pytest.raises(voxscope.LoadError, match="the plan has 2 parts"):
        voxscope.convert.run_part(plan, 5)


def test_the_dask_script_on_a_local_cluster_writes_the_one_process_bytes(tmp_path):
    # docs/cluster/convert-dask.py as a user runs it: a LocalCluster of 3 worker processes.
    nuclei = shared_data("nuclei-60x256x256.tif")
    whole = tmp_path / "whole.ome.zarr"
    voxscope.convert(nuclei, whole, format="0.5", chunk=32, shard=2, tile="3,3,2")
    out = tmp_path / "dask.ome.zarr"
    script = REPO / "docs" / "cluster" / "convert-dask.py"
    run = subprocess.run(
        [sys.executable, script, nuclei, out, "3", "format=0.5", "chunk=32", "shard=2", "tile=3,3,2"],
        capture_output=True, text=True, timeout=300,
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.count("objects") == 3 and "wrote" in run.stdout, run.stdout
    assert image_files(out) == image_files(whole)
