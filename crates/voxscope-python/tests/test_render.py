"""`voxscope.render` draws what `voxscope render` draws of the same voxels with the same
options (≥ 40 dB; in practice equal), for every option, every dtype and memory order, and the
composite of channels."""

import numpy as np
import pytest

import voxscope
from conftest import RAW_TYPES, cli_render, lit, psnr, save

SIZE = (96, 72)


def small_head(head):
    """Every second voxel of the real head: (31, 64, 64) values 0…255, spacing doubled."""
    voxels, (sz, sy, sx) = head
    return voxels[::2, ::2, ::2].astype(np.float64), (2 * sz, 2 * sy, 2 * sx)


# (keywords, the same options on the command line)
OPTIONS = [
    ({}, []),
    ({"mode": "mip"}, ["--mode", "mip"]),
    ({"preset": "ramp", "colormap": "viridis"}, ["--preset", "ramp", "--colormap", "viridis"]),
    (
        {"opacity": "binary", "threshold": 0.4, "window": (20, 180)},
        ["--opacity", "binary", "--threshold", "0.4", "--window=20:180"],
    ),
    ({"opacity_points": [(40, 0), (120, 0.6), (255, 1)]}, ["--opacity-points", "40:0,120:0.6,255:1"]),
    ({"opacity_points": "40:0,120:0.6,255:1"}, ["--opacity-points", "40:0,120:0.6,255:1"]),
    ({"shading": False, "density": 0.5}, ["--no-shading", "--density", "0.5"]),
    (
        {"ambient": 0.3, "diffuse": 0.6, "specular": 0.0, "shininess": 40},
        ["--ambient", "0.3", "--diffuse", "0.6", "--specular", "0", "--shininess", "40"],
    ),
    ({"level": 3}, ["--level", "3"]),
    ({"renderer": "dense", "nearest": True}, ["--renderer", "dense", "--nearest"]),
    ({"renderer": "bricks", "brick_size": 8}, ["--renderer", "bricks", "--brick-size", "8"]),
    ({"renderer": "stream", "gpu_memory": "64MiB"}, ["--renderer", "stream", "--gpu-memory", "64MiB"]),
    (
        {"clip_box": ((0, 0.8), (0.1, 1), (0, 0.6)), "clip_plane": (0, 0, -1, -0.7)},
        ["--clip-box", "0:0.6,0.1:1,0:0.8", "--clip-plane=-1,0,0,-0.7"],
    ),
    (
        {"azimuth": -60, "elevation": 35, "distance": 2.2, "fov": 30},
        ["--azimuth=-60", "--elevation", "35", "--distance", "2.2", "--fov", "30"],
    ),
    ({"heatmap": True, "opacity_correction": False}, ["--heatmap", "--no-opacity-correction"]),
    ({"pixel_lod": True, "size": (64, 48)}, ["--pixel-lod", "--size", "64x48"]),
]


@pytest.mark.parametrize("index", range(len(OPTIONS)))
def test_render_equals_the_command_line_for_every_option(head, tmp_path, images, index):
    keywords, words = OPTIONS[index]
    values, spacing = small_head(head)
    voxels = values.astype(np.int16)
    raw = tmp_path / "head.raw"
    voxels.tofile(raw)
    size = keywords.get("size", SIZE)
    options = words if "size" in keywords else [*words, "--size", f"{SIZE[0]}x{SIZE[1]}"]
    expected = cli_render(raw, voxels.shape, "i16", spacing, tmp_path / "cli.png", *options)
    got = voxscope.render(voxels, spacing=spacing, **{"size": size, **keywords})
    save(images, f"render_option_{index}", got)
    assert got.shape == (size[1], size[0], 4) and got.dtype == np.uint8
    assert lit(got) > 0.02, f"{keywords}: the image is black"
    assert psnr(got, expected) >= 40, f"{keywords}: {psnr(got, expected):.1f} dB"


def typed(values: np.ndarray, dtype: str) -> np.ndarray:
    """The head's values 0…255 spread over a range that suits `dtype`."""
    scale = {
        "uint8": (1, 0), "int8": (1, -128), "uint16": (200, 0), "int16": (100, -10000),
        "uint32": (1000, 7), "int32": (1000, -50000), "float32": (0.37, -20), "float64": (1e-3, 5),
    }[dtype]
    return (values * scale[0] + scale[1]).astype(dtype)


@pytest.mark.parametrize("dtype", list(RAW_TYPES))
def test_every_dtype_and_order_draws_as_the_command_line(head, tmp_path, images, dtype):
    values, spacing = small_head(head)
    voxels = typed(values, dtype)
    raw = tmp_path / "voxels.raw"
    voxels.tofile(raw)
    expected = cli_render(
        raw, voxels.shape, RAW_TYPES[dtype], spacing, tmp_path / "cli.png", "--size", "96x72"
    )
    c_order = voxscope.render(voxels, spacing=spacing, size=SIZE)
    fortran = voxscope.render(np.asfortranarray(voxels), spacing=spacing, size=SIZE)
    strided = np.zeros((voxels.shape[0], voxels.shape[1], 2 * voxels.shape[2]), dtype)
    strided[:, :, ::2] = voxels
    view = voxscope.render(strided[:, :, ::2], spacing=spacing, size=SIZE)
    save(images, f"dtype_{dtype}", c_order)
    assert lit(c_order) > 0.02
    for name, got in [("C", c_order), ("F", fortran), ("strided", view)]:
        assert psnr(got, expected) >= 40, f"{dtype} {name}: {psnr(got, expected):.1f} dB"


@pytest.mark.parametrize(
    "make, stored, raw_type",
    [
        (lambda v: v > 100, "uint8", "u8"),
        (lambda v: (v * 3).astype(np.int64) - 200, "int32", "i32"),
        (lambda v: (v.astype(np.uint64) << np.uint64(33)), "float64", "f64"),
        (lambda v: (v / 10).astype(np.float16), "float32", "f32"),
        (lambda v: v.astype(">u2"), "uint16", "u16"),
    ],
    ids=["bool", "int64", "uint64-large", "float16", "big-endian"],
)
def test_other_dtypes_convert_to_one_voxscope_stores(head, tmp_path, make, stored, raw_type):
    values, spacing = small_head(head)
    voxels = make(values)
    converted = voxels.astype(stored)
    raw = tmp_path / "voxels.raw"
    converted.tofile(raw)
    expected = cli_render(raw, voxels.shape, raw_type, spacing, tmp_path / "cli.png", "--size", "96x72")
    got = voxscope.render(voxels, spacing=spacing, size=SIZE)
    assert psnr(got, expected) >= 40


def test_channels_draw_as_the_composite_of_the_command_line(head, tmp_path, images):
    values, spacing = small_head(head)
    first = values.astype(np.uint16) * 100
    second = values[:, :, ::-1].astype(np.uint16) * 50  # the head mirrored left to right
    stack = np.stack([first, second])  # (c, z, y, x)
    files = []
    for index, channel in enumerate(stack):
        files.append(tmp_path / f"c{index}.raw")
        channel.tofile(files[-1])
    z, y, x = first.shape
    sz, sy, sx = spacing
    common = ["--raw", f"{x}x{y}x{z}:u16", f"--spacing={sx},{sy},{sz}", "--size", "96x72"]
    from conftest import run_cli
    from PIL import Image

    cases = [
        ({}, []),
        (
            {"channel_colors": ["cyan", (255, 128, 0)], "channel_window": {1: (0, 6000)}, "mode": "mip"},
            ["--channel-colors", "cyan,#ff8000", "--channel-window", "1:0:6000", "--mode", "mip"],
        ),
    ]
    for keywords, words in cases:
        out = tmp_path / "cli.png"
        run_cli("render", "--channels-from", ",".join(map(str, files)), *common, *words, "-o", out)
        expected = np.asarray(Image.open(out).convert("RGBA"))
        got = voxscope.render(stack, channel_axis=0, spacing=spacing, size=SIZE, **keywords)
        save(images, f"composite_{len(words)}", got)
        assert lit(got) > 0.02
        assert psnr(got, expected) >= 40, f"{keywords}: {psnr(got, expected):.1f} dB"
    # One channel of the stack is that channel alone; time as the other leading axis.
    one = voxscope.render(stack, channel_axis=0, channel=1, spacing=spacing, size=SIZE)
    alone = voxscope.render(second, spacing=spacing, size=SIZE)
    assert psnr(one, alone) == float("inf")
    series = np.stack([stack, stack[::-1]], axis=1)  # (c, t, z, y, x)
    later = voxscope.render(series, channel_axis=0, time=1, channel=0, spacing=spacing, size=SIZE)
    assert psnr(later, alone) == float("inf")


def test_a_path_renders_as_the_command_line(tmp_path, images):
    from conftest import run_cli, shared_data
    from PIL import Image

    path = shared_data("mri-head-128x128x62.nii.gz")
    run_cli("render", path, "--size", "96x72", "--preset", "ramp", "-o", tmp_path / "cli.png")
    expected = np.asarray(Image.open(tmp_path / "cli.png").convert("RGBA"))
    assert psnr(voxscope.render(path, size=SIZE, preset="ramp"), expected) >= 40
    volume = voxscope.open(path)
    assert psnr(voxscope.render(volume, size=SIZE, preset="ramp"), expected) >= 40
    assert psnr(voxscope.render(str(path), size="96x72", preset="ramp"), expected) >= 40


def test_a_stores_channels_stream_together_as_the_command_line_draws_them(tmp_path, images):
    """`channels=` names the channels of a store streamed together, as `--channels` does; by
    default its omero active ones stream (nine channels, 1, 3, 4 and 8 active)."""
    from conftest import REPO, run_cli
    from PIL import Image

    store = REPO / "tests/data/ome-zarr/channels9-v05-sharded.ome.zarr"
    for keywords, words in [
        ({}, []),
        ({"channels": [8, 1], "mode": "mip"}, ["--channels", "8,1", "--mode", "mip"]),
        ({"channels": 3}, ["--channels", "3"]),
    ]:
        out = tmp_path / "cli.png"
        run_cli("render", store, "--renderer", "stream", "--lod-scale", "0", "--size", "96x72",
                *words, "-o", out)
        expected = np.asarray(Image.open(out).convert("RGBA"))
        drawn = voxscope.render(store, renderer="stream", lod_scale=0, size=SIZE, **keywords)
        save(images, f"stream-channels-{len(words)}", drawn)
        assert lit(drawn) > 0.02, keywords
        assert psnr(drawn, expected) >= 40, keywords
    with pytest.raises(ValueError, match="no channel 9"):
        voxscope.render(store, renderer="stream", channels=[9], size=SIZE)


def test_chosen_channels_in_memory_are_the_command_lines(tmp_path, images):
    """`channels=` in memory loads those channels of the file alone, colors and windows by
    their number in the file, as `--channels` does."""
    from conftest import REPO, run_cli
    from PIL import Image

    store = REPO / "tests/data/ome-zarr/channels9-v05-sharded.ome.zarr"
    out = tmp_path / "cli.png"
    run_cli("render", store, "--size", "96x72", "--channels", "8,1", "--channel-window",
            "8:0:9000", "-o", out)
    expected = np.asarray(Image.open(out).convert("RGBA"))
    drawn = voxscope.render(store, channels=[8, 1], channel_window="8:0:9000", size=SIZE)
    save(images, "memory-channels-8-1", drawn)
    assert lit(drawn) > 0.02
    assert psnr(drawn, expected) >= 40


def test_labels_are_drawn_over_the_image_as_the_command_line_draws_them(tmp_path, images):
    """`labels=`, `labels_opacity=` and `labels_hide=` are `--labels`, `--labels-opacity` and
    `--labels-hide`: over one volume and over the composite of channels; fixed per Renderer."""
    from conftest import REPO, run_cli
    from PIL import Image

    data = REPO / "tests/data/labels-overlay"
    for store, keywords, words in [
        (data / "cells-v04.ome.zarr", {"labels": "cells"}, ["--labels", "cells"]),
        (data / "cells-v04.ome.zarr",
         {"labels": ["cells", "regions"], "labels_opacity": 0.5, "labels_hide": [2]},
         ["--labels", "cells,regions", "--labels-opacity", "0.5", "--labels-hide", "2"]),
        (data / "cells-channels-v05.ome.zarr", {"labels": "cells"}, ["--labels", "cells"]),
    ]:
        out = tmp_path / "cli.png"
        run_cli("render", store, "--size", "96x72", *words, "-o", out)
        expected = np.asarray(Image.open(out).convert("RGBA"))
        drawn = voxscope.render(str(store), size=SIZE, **keywords)
        plain = voxscope.render(str(store), size=SIZE)
        save(images, f"labels-{store.name}-{len(words)}", drawn)
        assert psnr(drawn, expected) >= 40, keywords
        assert (drawn != plain).any(axis=2).sum() > 100, keywords
    renderer = voxscope.Renderer(str(data / "cells-v04.ome.zarr"), labels="cells", size=SIZE)
    rendered = renderer.render()
    assert psnr(rendered, voxscope.render(str(data / "cells-v04.ome.zarr"),
                                          labels="cells", size=SIZE)) >= 40
    renderer.draw(azimuth=80)
    renderer.draw()
    assert (renderer.read() == rendered).all(), "read() gives the frame as render() does"
    with pytest.raises(TypeError, match="labels= is chosen when the Renderer is made"):
        renderer.render(labels="regions")
    with pytest.raises(ValueError, match="nuclei"):
        voxscope.render(str(data / "cells-v04.ome.zarr"), labels="nuclei", size=SIZE)
