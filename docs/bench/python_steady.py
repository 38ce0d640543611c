"""Python's frame once the GPU's clocks are up: what python-cli.sh compares with the command line.

usage: python3 python_steady.py HEAD.npz [FRAMES WIDTH HEIGHT AZIMUTH]

The peers' harness (peer_bench.py) times one batch right after 100 warm-up frames, DVR first in a
fresh process: on an H100 that batch runs while the GPU's clocks still ramp up from idle (345 MHz),
so the mode measured first reads slow (run 151: DVR 0.153 ms there, 0.123-0.126 ms here). The
command line's `bench` warms up until its GPU times are steady. This script draws what the harness
draws (voxscope.Renderer, bricks, opacity gray or MIP, window 0:255, unshaded, the turn of FRAMES
azimuths from AZIMUTH at 3 radii, elevation 20, field of view 45) and reports, per mode, the
median of 5 batches (FRAMES draw() calls, then finish()), the modes in the order DVR, MIP, MIP,
DVR, so neither is always first. One JSON line per mode and pass.
"""
import json
import statistics
import sys
import time

import numpy as np
import voxscope


def batches(renderer, frames, azimuth, step, count=5):
    """Milliseconds per frame of `count` batches of the turn."""
    out = []
    for _ in range(count):
        renderer.draw(azimuth=azimuth)
        renderer.finish()
        started = time.perf_counter()
        for i in range(frames):
            renderer.draw(azimuth=azimuth - (i + 1) * step)
        renderer.finish()
        out.append((time.perf_counter() - started) / frames * 1e3)
    return out


def main(path, frames=100, width=1024, height=768, azimuth=150.0):
    volume = np.load(path)["v"]
    step = 360.0 / frames
    for index, mode in enumerate(("dvr", "mip", "mip", "dvr")):
        transfer = dict(opacity="gray") if mode == "dvr" else dict(mode="mip")
        renderer = voxscope.Renderer(volume, renderer="bricks", size=(width, height),
                                     window=(0, 255), shading=False, elevation=20, distance=3.0,
                                     fov=45, **transfer)
        for i in range(101):
            renderer.render(azimuth=azimuth - i * step)
        ms = batches(renderer, frames, azimuth, step)
        print(json.dumps(dict(peer="voxscope-steady", mode=mode, pass_=index, frames=frames,
                              w=width, h=height, ms_batch=round(statistics.median(ms), 4),
                              batches=[round(m, 4) for m in ms], device=renderer.device)),
              flush=True)


if __name__ == "__main__":
    if len(sys.argv) not in (2, 6):
        raise SystemExit(__doc__)
    args = sys.argv[1:]
    main(args[0], *(int(a) for a in args[1:4]), *(float(a) for a in args[4:5]))
