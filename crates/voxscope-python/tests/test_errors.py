"""Errors raise Python exceptions carrying the command line's one-line message: the same
words `voxscope render` prints after `error: ` for the same option or file."""

import numpy as np
import pytest

import voxscope
from conftest import FIXTURES, run_cli


@pytest.fixture(scope="module")
def raw_head(head, tmp_path_factory):
    voxels, spacing = head
    path = tmp_path_factory.mktemp("raw") / "head.raw"
    voxels.tofile(path)
    z, y, x = voxels.shape
    sz, sy, sx = spacing
    return path, ["--raw", f"{x}x{y}x{z}:i16", f"--spacing={sx},{sy},{sz}"], voxels, spacing


def cli_error(*args) -> str:
    """The command line's one-line error for `args` (it must fail)."""
    result = run_cli(*args, check=False)
    assert result.returncode != 0, f"voxscope {args} did not fail"
    first = next(line for line in result.stderr.splitlines() if line.strip())
    return first.removeprefix("error: ").strip()


BAD_OPTIONS = [
    ({"preset": "bogus"}, ["--preset", "bogus"]),
    ({"opacity": "gray", "preset": "ramp"}, ["--opacity", "gray", "--preset", "ramp"]),
    ({"shininess": 0}, ["--shininess", "0"]),
    ({"threshold": 1.5}, ["--threshold", "1.5"]),
    ({"colormap": "rainbow"}, ["--colormap", "rainbow"]),
    ({"window": "1:x"}, ["--window", "1:x"]),
    ({"opacity_points": [(10, 0.5), (5, 1)]}, ["--opacity-points", "10:0.5,5:1"]),
    ({"clip_box": ((0, 1), (0, 1), (0.6, 0.2))}, ["--clip-box", "0.6:0.2,0:1,0:1"]),
    ({"clip_plane": (0, 0, 0, 1)}, ["--clip-plane", "0,0,0,1"]),
    ({"gpu_memory": "3 parsecs", "renderer": "stream"}, ["--gpu-memory", "3 parsecs", "--renderer", "stream"]),
    ({"size": (0, 10)}, ["--size", "0x10"]),
    ({"brick_size": 12}, ["--brick-size", "12"]),
    ({"mode": "xray"}, ["--mode", "xray"]),
    ({"max_wait": -1}, ["--max-wait=-1"]),
    ({"density": "thick"}, ["--density", "thick"]),
    ({"level": "deep"}, ["--level", "deep"]),
    ({"azimuth": "left"}, ["--azimuth", "left"]),
    ({"renderer": "raytracer"}, ["--renderer", "raytracer"]),
    ({"uploads": "post"}, ["--uploads", "post"]),
    ({"lod_scale": 100}, ["--lod-scale", "100"]),
    ({"ram_cache": "0"}, ["--ram-cache", "0"]),
    ({"channel_colors": ["green", "nope"]}, ["--channel-colors", "green,nope"]),
    ({"channel_window": "1:2"}, ["--channel-window", "1:2"]),
    ({"preset": "ramp", "tf": "x.ron"}, ["--preset", "ramp", "--tf", "x.ron"]),
]


@pytest.mark.parametrize("index", range(len(BAD_OPTIONS)))
def test_a_bad_value_raises_the_command_lines_message(raw_head, tmp_path, index):
    keywords, words = BAD_OPTIONS[index]
    path, layout, voxels, spacing = raw_head
    expected = cli_error("render", path, *layout, *words, "-o", tmp_path / "x.png")
    with pytest.raises(ValueError) as raised:
        voxscope.render(voxels, spacing=spacing, **keywords)
    assert str(raised.value) == expected


def test_a_file_that_cannot_be_read_raises_load_error_with_the_message(tmp_path, raw_head):
    missing = tmp_path / "missing.nii.gz"
    with pytest.raises(voxscope.LoadError) as raised:
        voxscope.open(missing)
    assert str(raised.value) == cli_error("info", missing)
    broken = tmp_path / "broken.nii"
    broken.write_bytes(b"\x5c\x01\x00\x00" + b"\x00" * 100)
    with pytest.raises(voxscope.LoadError) as raised:
        voxscope.render(broken)
    assert str(raised.value) == cli_error("render", broken, "-o", tmp_path / "x.png")
    assert isinstance(raised.value, voxscope.VoxscopeError)
    # A transfer function file that is not one.
    tf = tmp_path / "tf.ron"
    tf.write_text("not ron at all")
    path, layout, voxels, spacing = raw_head
    with pytest.raises(voxscope.LoadError) as raised:
        voxscope.render(voxels, spacing=spacing, tf=tf)
    assert str(raised.value) == cli_error("render", path, *layout, "--tf", tf, "-o", tmp_path / "x.png")


def test_wrong_keywords_and_arrays_raise_type_and_value_errors(raw_head):
    _, _, voxels, spacing = raw_head
    with pytest.raises(TypeError, match="unexpected keyword argument 'colour'"):
        voxscope.render(voxels, colour="red")
    with pytest.raises(TypeError, match="shading= takes True or False"):
        voxscope.render(voxels, shading="off")
    with pytest.raises(ValueError, match="2 dimensions is not a volume"):
        voxscope.render(np.zeros((4, 4)))
    with pytest.raises(TypeError, match="complex128 are not volumes"):
        voxscope.render(np.zeros((4, 4, 4), complex))
    with pytest.raises(ValueError, match="needs channel_axis"):
        voxscope.render(np.zeros((2, 2, 4, 4, 4)))
    with pytest.raises(ValueError, match="channel 3 is beyond its 2 channels"):
        voxscope.render(np.zeros((2, 4, 4, 4)), channel_axis=0, channel=3)
    with pytest.raises(ValueError, match=r"spacing \(0.0, 1.0, 1.0\) needs three positive numbers"):
        voxscope.render(voxels, spacing=(0, 1, 1))
    with pytest.raises(ValueError, match="drawn by the dense renderer"):
        voxscope.render(np.zeros((2, 4, 4, 4)), channel_axis=0, renderer="octree")
    renderer = voxscope.Renderer(voxels[::4, ::4, ::4], size=(16, 12))
    with pytest.raises(TypeError, match="renderer= is chosen when the Renderer is made"):
        renderer.render(renderer="dense")
    with pytest.raises(ValueError, match=r"no level 5 \(it has 3: 0 to 2\)"):
        voxscope.open(FIXTURES / "head-v04-zstd.ome.zarr").read(5)
