"""voxscope in Python: volumes rendered on the GPU into numpy images.

    import numpy as np, voxscope
    vol = voxscope.open("s3://bucket/cells.ome.zarr")      # any path or URL the CLI opens
    a = vol.read(level=2)                                   # numpy (z, y, x)
    img = voxscope.render(a, spacing=(2.5, 0.7, 0.7), mode="mip", size=(1024, 768))
    r = voxscope.Renderer(vol, size=(1920, 1080), gpu_memory="2GiB")   # stays on the GPU
    frames = [r.render(azimuth=az, preset="ct-bone") for az in range(0, 360, 2)]
    voxscope.view(a)                                        # the app; Python goes on

Arrays are numpy's (z, y, x), spacing in the same order (napari's `scale`); channels and time
are leading axes (`channel_axis=`). Every rendering keyword is the `voxscope render` option of
the same name (`opacity_points=` is `--opacity-points`): the same meaning, defaults and checks,
and a bad value raises ValueError with the command line's one-line message. A string value is
the option's text as typed on the command line; tuples of axes are in (z, y, x) order.
"""

from ._voxscope import (
    LoadError,
    Renderer,
    RenderError,
    Volume,
    VoxscopeError,
    __version__,
    _convert_finalize,
    _convert_plan,
    _convert_run_part,
    device,
    open,
    render,
)
from ._voxscope import convert as _convert
from ._view import Viewer, view


def convert(source, output, **options):
    return _convert(source, output, **options)


convert.__doc__ = _convert.__doc__
# The conversion's three steps, for a scheduler that runs them across machines
# (docs/cluster.md): `plan = convert.plan(src, out, parts=N, **options)`, then
# `convert.run_part(plan, i)` for each i (any order, any process), then `convert.finalize(plan)`.
convert.plan = _convert_plan
convert.run_part = _convert_run_part
convert.finalize = _convert_finalize

__all__ = [
    "LoadError",
    "RenderError",
    "Renderer",
    "Viewer",
    "Volume",
    "VoxscopeError",
    "__version__",
    "convert",
    "device",
    "open",
    "render",
    "view",
]
