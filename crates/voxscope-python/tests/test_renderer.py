"""`voxscope.Renderer` keeps a volume on the GPU: its frames differ as the camera moves and
equal single `render` calls of the same keywords, whatever it drew before (a transfer function
recolored on the GPU, another size); draw/finish/read give what render gives; the streaming
renderer refines a store to its complete picture, and a view beyond its budget warns that it is
budget-limited, naming the budget that holds it (which then draws it without a warning)."""

import re
import threading
import warnings

import numpy as np
import pytest

import voxscope
from conftest import FIXTURES, lit, psnr, save

SIZE = (96, 72)


@pytest.fixture(scope="module")
def small(head):
    voxels, (sz, sy, sx) = head
    return voxels[::2, ::2, ::2].copy(), (2 * sz, 2 * sy, 2 * sx)


def test_frames_differ_as_the_camera_moves_and_equal_single_renders(small, images):
    voxels, spacing = small
    renderer = voxscope.Renderer(voxels, spacing=spacing, size=SIZE)
    assert renderer.kind in ("octree", "bricks") and renderer.depth == 6
    frames = [renderer.render(azimuth=azimuth) for azimuth in range(0, 360, 45)]
    for index, frame in enumerate(frames):
        save(images, f"renderer_azimuth_{index * 45}", frame)
        assert lit(frame) > 0.02
    for a, b in zip(frames, frames[1:]):
        assert psnr(a, b) < 30, "a turn of 45° must change the picture"
    for azimuth in (0, 135, 270):
        single = voxscope.render(voxels, spacing=spacing, size=SIZE, azimuth=azimuth)
        assert np.array_equal(frames[azimuth // 45], single)


def test_each_frame_takes_its_own_transfer_function_size_and_clip(small):
    voxels, spacing = small
    renderer = voxscope.Renderer(voxels, spacing=spacing, size=SIZE, preset="ramp")
    cases = [
        {"elevation": 50},
        {"opacity": "binary", "threshold": 0.5},  # replaces the Renderer's preset
        {"mode": "mip", "window": (0, 120)},
        {"shading": False, "colormap": "magma"},
        {"size": (40, 30), "level": 2},
        {"clip_box": ((0, 1), (0, 1), (0, 0.5))},
        {},
    ]
    for keywords in cases:
        frame = renderer.render(**keywords)
        merged = {"size": SIZE, "preset": "ramp", **keywords}
        if "opacity" in keywords:
            del merged["preset"]
        single = voxscope.render(voxels, spacing=spacing, **merged)
        assert frame.shape == single.shape
        assert np.array_equal(frame, single), f"{keywords}: {psnr(frame, single):.1f} dB"


def test_camera_keywords_alone_draw_as_single_renders_of_them_after_any_frame(small):
    # A camera sweep's keywords (floats and ints, read as numbers) draw what the same numbers
    # as words, strings or numpy scalars draw, over the Renderer's own transfer function
    # whatever frame came before; a bool is no number.
    voxels, spacing = small
    renderer = voxscope.Renderer(voxels, spacing=spacing, size=SIZE, preset="ramp", elevation=10)
    expected = voxscope.render(
        voxels, spacing=spacing, size=SIZE, preset="ramp", elevation=10, azimuth=40.5, distance=2
    )
    sweeps = [
        dict(azimuth=40.5, distance=2),
        dict(azimuth=np.float64(40.5), distance=np.int64(2)),
        dict(azimuth="40.5", distance="2.0", fov=None),
    ]
    for keywords in sweeps:
        for before in ({"mode": "mip", "window": (0, 90)}, {"azimuth": 200}, {}):
            renderer.render(**before)
            assert np.array_equal(renderer.render(**keywords), expected), (keywords, before)
    with pytest.raises(ValueError, match="--azimuth <AZIMUTH>"):
        renderer.draw(azimuth=True)


@pytest.mark.parametrize("kind", ["octree", "dense", "bricks", "stream"])
def test_draw_finish_and_read_give_the_rendered_frame(small, kind):
    voxels, spacing = small
    renderer = voxscope.Renderer(voxels, spacing=spacing, size=SIZE, renderer=kind, max_wait=60)
    assert renderer.kind == kind
    expected = renderer.render(azimuth=77)
    for azimuth in range(0, 360, 30):
        renderer.draw(azimuth=azimuth)
    renderer.draw(azimuth=77)
    renderer.finish()
    assert psnr(renderer.read(), expected) >= 40
    assert sum(bytes for _, bytes in renderer.gpu_bytes) > 0


def test_the_composite_recolors_per_frame(small):
    voxels, spacing = small
    stack = np.stack([voxels, voxels[:, ::-1, :]])
    renderer = voxscope.Renderer(stack, channel_axis=0, spacing=spacing, size=SIZE)
    assert renderer.kind == "composite"
    frame = renderer.render(channel_colors=["red", "blue"], channel_window={0: (0, 90)})
    single = voxscope.render(
        stack, channel_axis=0, spacing=spacing, size=SIZE,
        channel_colors=["red", "blue"], channel_window={0: (0, 90)},
    )
    assert np.array_equal(frame, single)
    assert not np.array_equal(frame, renderer.render())


def test_a_store_streams_to_its_complete_picture(images):
    store = voxscope.open(FIXTURES / "head-v04-zstd.ome.zarr")
    streamed = voxscope.Renderer(store, renderer="stream", gpu_memory="32MiB", size=SIZE)
    assert streamed.kind == "stream"
    frame = streamed.render(azimuth=200, preset="ramp")
    save(images, "renderer_stream", frame)
    in_memory = voxscope.render(store, renderer="bricks", size=SIZE, azimuth=200, preset="ramp")
    assert lit(frame) > 0.02
    assert psnr(frame, in_memory) >= 35, f"{psnr(frame, in_memory):.1f} dB"


def test_a_view_beyond_the_budget_says_so_and_the_budget_it_names_holds_it(images):
    near_mip = dict(renderer="stream", mode="mip", distance=0.6, size=(128, 96))
    with pytest.warns(UserWarning, match="complete at the budget") as caught:
        limited = voxscope.render("synthetic:ct:256", gpu_memory="4MiB", **near_mip)
    said = next(str(w.message) for w in caught if "complete at the budget" in str(w.message))
    assert "budget-limited: finest level" in said, said
    named = re.search(r"a GPU budget of ([0-9.]+) (MiB|GiB) holds it all", said)
    assert named, said
    save(images, "renderer_budget_limited", limited)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        full = voxscope.render("synthetic:ct:256", gpu_memory=named[1] + named[2], **near_mip)
    assert lit(full) > 0.05
    assert not np.array_equal(full, limited)


def test_a_renderer_says_the_budgets_limit_once_until_it_changes():
    near_mip = dict(mode="mip", distance=0.6)
    renderer = voxscope.Renderer(
        "synthetic:ct:256", renderer="stream", gpu_memory="4MiB", size=(128, 96)
    )
    said = []
    for azimuth in (30, 30, 30):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            renderer.render(azimuth=azimuth, **near_mip)
        said.append([str(w.message) for w in caught if "complete at the budget" in str(w.message)])
    assert len(said[0]) == 1, said
    assert said[1] == [] and said[2] == [], said
    # A view the budget limits otherwise (or not at all) is said anew.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        renderer.render(azimuth=30, mode="mip", distance=3.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        renderer.render(azimuth=30, **near_mip)
    again = [str(w.message) for w in caught if "complete at the budget" in str(w.message)]
    assert len(again) == 1, again


def test_renderers_in_threads_draw_as_alone(small):
    voxels, spacing = small
    renderer = voxscope.Renderer(voxels, spacing=spacing, size=SIZE)
    expected = {azimuth: renderer.render(azimuth=azimuth) for azimuth in (10, 100, 190)}
    results, errors = {}, []

    def draw(azimuth):
        try:
            results[azimuth] = renderer.render(azimuth=azimuth)
        except Exception as error:  # reported below
            errors.append(error)

    threads = [threading.Thread(target=draw, args=(a,)) for a in expected]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors
    for azimuth, frame in expected.items():
        assert np.array_equal(results[azimuth], frame)
