"""Time peer volume renderers on one volume: vispy (OpenGL over EGL), pygfx (wgpu over Vulkan)
and VTK (vtkGPUVolumeRayCastMapper, OpenGL over EGL; what ParaView and 3D Slicer use), and
voxscope beside them through its Python module (`voxscope.Renderer`, wgpu over Vulkan), in the
same frame loop.

A copy of ../shared/peers/peer_bench.py (the peers' harness, unchanged for them) with voxscope
as a fourth peer; docs/benchmarks.md, "Python", says how it is run.

usage: python3 peer_bench.py VOLUME.npz [frames=100] [width=1024] [height=768]
       python3 peer_bench.py --sheet DIR   (sheets + image comparison of the PNGs in DIR, e.g.
                                            after unpacking the shots of several device calls)
env:   PEERS=vispy,pygfx,vtk,voxscope (default: all four, each in its own child process, so one peer's
       crash or hang costs only its own rows); OUT=folder for the PNGs (default /tmp);
       PEER_TIMEOUT=seconds per peer (default 300); VTK_DEFAULT_OPENGL_WINDOW (default here
       vtkEGLRenderWindow), VTK_DEFAULT_EGL_DEVICE_INDEX (VTK's own, default 0).

VOLUME.npz holds `v` (uint8, numpy order (z, y, x): last axis is x) and optionally `spacing`
(voxel size per array axis, (z, y, x); default 1, 1, 1); a plain .npy is read too.

Same scene for every peer:
- world: voxel (i, j, k) of v[k, j, i] sits at (i*sx, j*sy, k*sz); the volume centre c is the
  middle of the first and last voxel centres; r = half the diagonal of the box n*spacing.
- camera: perspective, vertical fov 45 deg, up +z, looking at c from distance 3r, elevation 20 deg,
  azimuth 30 deg in vispy's TurntableCamera convention: eye = c + 3r*(cos(el)sin(az),
  -cos(el)cos(az), sin(el)). Black background; values mapped with window [0, 255].
- dvr: gray colour ramp, opacity ramp alpha = value/255 per sample (no shading), front-to-back
  compositing with early termination, linear interpolation, step 0.8 voxel.
  vispy method 'translucent' (with an RGBA colormap: its default 'grays' has alpha 1, which made
  the first sample on the box face opaque: the black image of the 2026-11-23 run); VTK composite
  blend with ScalarOpacityUnitDistance = SampleDistance so per-sample alpha is the same ramp.
  pygfx 0.17 has no DVR material (only mip/minip/iso), so it has no dvr row.
  voxscope: opacity "gray" (alpha = value per voxel of path, corrected for the step), window
  0:255, unshaded, the bricks renderer (its trilinear march; `VOXSCOPE_RENDERER` picks another).
- mip: gray colormap of the maximum along the ray (vispy 'mip', pygfx VolumeMipMaterial, VTK
  SetBlendModeToMaximumIntensity with constant opacity 1, voxscope mode "mip").
- voxscope's camera is the same eye: its azimuth turns the other way from the front (its eye is
  c + d(sin az, cos az, ...)), so vispy's azimuth a is voxscope's 180 - a; distance 3 radii
  of the same bounding sphere, fov 45, up +z.

Timing, per (peer, mode), after one warm-up render (upload, shader compile) whose image is saved:
- ms_readback: median over `frames` single renders, each followed by a read of the RGBA pixels
  to host memory (so the GPU has finished), camera azimuth advancing 360/frames deg per frame.
- ms_batch: `frames` renders (same camera sweep) issued back to back, then one glFinish / queue
  wait; total / frames. Includes each tool's per-frame Python and driver work (what its user
  gets); it is the GPU-bound estimate when the GPU is the bottleneck.
- voxscope: ms_readback is `Renderer.render()` (draw, then the image read back into numpy);
  ms_batch is `frames` calls of `Renderer.draw()` then one `Renderer.finish()`. ms_call (its
  rows only) is a frame's CPU cost: the mean wall time of one `draw()` call as the
  interpreter sees it (its camera keywords read as numbers, the frame encoded and submitted as
  the command line's are, the GIL released around it), without waiting for the GPU;
  ms_call_p95 its 95th percentile.
Prints one JSON line per (peer, mode); writes $OUT/{peer}_{mode}_{tag}.png (tag = file stem) at
az 30 and, in the parent, $OUT/sheet_{tag}.png with all of them side by side plus an image
comparison line per mode (mean |difference| of the gray images against the first peer's).
"""
import json
import math
import os
import statistics
import subprocess
import sys
import time

import numpy as np

ALL_PEERS = ("vispy", "pygfx", "vtk", "voxscope")
FOV, AZ0, EL, DIST_R = 45.0, 30.0, 20.0, 3.0

OUT = os.environ.get("OUT") or "/tmp"
SHEET = len(sys.argv) > 1 and sys.argv[1] == "--sheet"
if len(sys.argv) < 2 or (SHEET and len(sys.argv) < 3):
    raise SystemExit(__doc__)
if not SHEET:
    path = sys.argv[1]
    frames = int(sys.argv[2]) if len(sys.argv) > 2 else 100
    W = int(sys.argv[3]) if len(sys.argv) > 3 else 1024
    H = int(sys.argv[4]) if len(sys.argv) > 4 else 768
    tag = os.path.basename(path).split(".")[0]


def load(p):
    d = np.load(p)
    if hasattr(d, "files"):
        v = d["v"]
        sp = d["spacing"] if "spacing" in d.files else np.ones(3)
    else:
        v, sp = d, np.ones(3)
    if v.dtype != np.uint8:
        raise SystemExit(f"{p}: expected uint8, got {v.dtype}")
    return np.ascontiguousarray(v), np.asarray(sp, dtype=np.float64)


def child_main(peer):
    vol, spacing_zyx = load(path)
    sp = spacing_zyx[::-1].copy()                      # (sx, sy, sz)
    n = np.array(vol.shape[::-1], dtype=np.float64)    # (nx, ny, nz)
    center = (n - 1) / 2 * sp
    radius = 0.5 * float(np.linalg.norm(n * sp))
    dist = DIST_R * radius
    step_deg = 360.0 / max(frames, 1)

    def eye(az):
        a, e = math.radians(az), math.radians(EL)
        return center + dist * np.array([math.cos(e) * math.sin(a), -math.cos(e) * math.cos(a), math.sin(e)])

    def report(mode, method, ts, batch_s, img, info):
        img = np.asarray(img)
        if img.ndim == 3 and img.shape[2] == 4:
            img = img[..., :3]
        gray = img.astype(np.float32).mean(axis=2)
        r = dict(peer=peer, mode=mode, method=method, volume=tag, shape=list(vol.shape),
                 spacing=[float(s) for s in spacing_zyx], w=W, h=H, frames=frames,
                 ms_readback=round(statistics.median(ts) * 1e3, 3), ms_batch=round(batch_s / frames * 1e3, 3),
                 ms_readback_p95=round(float(np.percentile(ts, 95)) * 1e3, 3),
                 img_mean=round(float(gray.mean()), 2), img_lit=round(float((gray > 8).mean()), 4),
                 img_size=[int(img.shape[1]), int(img.shape[0])], **info)
        print(json.dumps(r), flush=True)
        try:
            from PIL import Image
            Image.fromarray(np.ascontiguousarray(img.astype(np.uint8))).save(f"{OUT}/{peer}_{mode}_{tag}.png")
        except Exception as e:  # never lose the timing for an image problem
            print(f"# image save failed: {e}", flush=True)

    print(f"# {peer}: volume {path} shape(z,y,x)={vol.shape} spacing(z,y,x)={spacing_zyx.tolist()} "
          f"out={W}x{H} frames={frames} centre={np.round(center, 2).tolist()} r={radius:.2f} "
          f"dist={dist:.2f}", flush=True)

    # ------------------------------------------------------------------ vispy
    def run_vispy():
        import vispy
        vispy.use(app="egl")
        from vispy import scene, gloo
        from vispy.color import Colormap
        from vispy.gloo import gl
        renderer = None
        for mode, method in (("dvr", "translucent"), ("mip", "mip")):
            canvas = scene.SceneCanvas(size=(W, H), show=False, bgcolor="black")
            view = canvas.central_widget.add_view()
            # DVR: colour = alpha = value (RGBA ramp). MIP: plain gray (alpha 1, as vispy's 'grays').
            cmap = Colormap([[0, 0, 0, 0], [1, 1, 1, 1]]) if mode == "dvr" else "grays"
            v = scene.visuals.Volume(vol, parent=view.scene, method=method, cmap=cmap, clim=(0, 255),
                                     relative_step_size=0.8, interpolation="linear", texture_format="auto")
            v.transform = scene.STTransform(scale=tuple(sp))
            cam = scene.TurntableCamera(fov=FOV, elevation=EL, azimuth=AZ0, distance=dist,
                                        center=tuple(center), up="+z")
            view.camera = cam
            img = canvas.render()  # warm-up: upload + compile; the saved image (az 30)
            if renderer is None:
                renderer = gl.glGetParameter(gl.GL_RENDERER)
                e = cam.transform.map([0, 0, 0, 1])
                got = np.asarray(e[:3]) / e[3]
                if not np.allclose(got, eye(AZ0), atol=1e-3 * dist):
                    print(f"# WARNING vispy eye {got} != expected {eye(AZ0)}", flush=True)
            ts = []
            for i in range(frames):
                cam.azimuth = AZ0 + (i + 1) * step_deg
                t = time.perf_counter(); canvas.render(); ts.append(time.perf_counter() - t)
            # batch: draw into one fbo many times, finish once
            fbo = gloo.FrameBuffer(color=gloo.RenderBuffer((H, W)), depth=gloo.RenderBuffer((H, W)))
            canvas.push_fbo(fbo, (0, 0), (W, H))
            canvas._draw_scene(); gl.glFinish()
            t = time.perf_counter()
            for i in range(frames):
                cam.azimuth = AZ0 + (i + 1) * step_deg
                canvas._draw_scene()
            gl.glFinish(); batch = time.perf_counter() - t
            canvas.pop_fbo()
            report(mode, method, ts, batch, img,
                   dict(version=f"vispy {vispy.__version__}", renderer=str(renderer),
                        settings="texture r8 (texture_format auto), relative_step_size 0.8"))
            canvas.close()

    # ------------------------------------------------------------------ pygfx
    def run_pygfx():
        import pygfx as gfx
        import wgpu
        from rendercanvas.offscreen import RenderCanvas
        canvas = RenderCanvas(size=(W, H), pixel_ratio=1)
        renderer = gfx.renderers.WgpuRenderer(canvas, pixel_ratio=1, pixel_filter="nearest", ppaa="none")
        info = renderer.device.adapter.info
        adapter = f"{info.get('device', '?')} ({info.get('backend_type', '?')}, {info.get('description', '')})"
        print(f"# pygfx adapter {adapter}", flush=True)
        scene_ = gfx.Scene()
        tex = gfx.Texture(vol, dim=3)
        # Gray ramp with alpha 1, like vispy's 'grays' and VTK's MIP here. (pygfx's own gfx.cm.gray has
        # alpha = value, which darkens a MIP over black to value^2; timing is the same either way.)
        t = np.linspace(0, 1, 256, dtype=np.float32)
        ramp = gfx.TextureMap(gfx.Texture(np.stack([t, t, t, np.ones_like(t)], 1), dim=1, colorspace="srgb"),
                              filter="linear", wrap="clamp")
        mesh = gfx.Volume(gfx.Geometry(grid=tex), gfx.VolumeMipMaterial(clim=(0, 255), map=ramp))
        mesh.local.scale = tuple(float(s) for s in sp)
        scene_.add(gfx.Background.from_color("#000"), mesh)
        camera = gfx.PerspectiveCamera(FOV, 1, depth_range=(0.05 * dist, 10 * dist))

        def place(az):
            camera.local.position = tuple(eye(az))
            camera.world.reference_up = (0, 0, 1)
            camera.look_at(tuple(center))

        place(AZ0)
        canvas.request_draw(lambda: renderer.render(scene_, camera))
        img = canvas.draw()  # warm-up; the saved image
        ts = []
        for i in range(frames):
            place(AZ0 + (i + 1) * step_deg)
            t = time.perf_counter(); canvas.draw(); ts.append(time.perf_counter() - t)
        dev = renderer.device
        # Wait for all submitted GPU work: read back a 4-byte buffer (queue order puts the copy after
        # every earlier submission). wgpu 0.32's on_submitted_work_done_sync() raises a cffi TypeError.
        probe = dev.create_buffer(size=4, usage=wgpu.BufferUsage.COPY_SRC | wgpu.BufferUsage.COPY_DST)

        def gpu_wait():
            dev.queue.read_buffer(probe)

        renderer.render(scene_, camera, flush=True); gpu_wait()
        t = time.perf_counter()
        for i in range(frames):
            place(AZ0 + (i + 1) * step_deg)
            renderer.render(scene_, camera, flush=True)
        gpu_wait()
        batch = time.perf_counter() - t
        report("mip", "VolumeMipMaterial", ts, batch, img,
               dict(version=f"pygfx {gfx.__version__}, wgpu {wgpu.__version__}", renderer=adapter,
                    settings="texture r8unorm, step 0.8 (pygfx: clamp(sqrt(max n)/20, .1, .8)), ppaa none, gray ramp alpha 1"))

    # ------------------------------------------------------------------ VTK
    def run_vtk():
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
        import vtkmodules
        import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (factory overrides: OpenGL classes)
        import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401  (vtkOpenGLGPUVolumeRayCastMapper)
        from vtkmodules.vtkCommonCore import vtkUnsignedCharArray, VTK_UNSIGNED_CHAR
        from vtkmodules.vtkCommonDataModel import vtkImageData, vtkPiecewiseFunction
        from vtkmodules.vtkRenderingCore import (vtkColorTransferFunction, vtkRenderWindow, vtkRenderer,
                                                 vtkVolume, vtkVolumeProperty)
        from vtkmodules.vtkRenderingVolume import vtkGPUVolumeRayCastMapper
        from vtkmodules.util.numpy_support import numpy_to_vtk
        try:
            from vtkmodules.vtkCommonCore import vtkVersion
            version = vtkVersion.GetVTKVersion()
        except Exception:
            version = getattr(vtkmodules, "__version__", "?")

        image = vtkImageData()
        image.SetDimensions(*[int(x) for x in n])
        image.SetSpacing(*[float(s) for s in sp])
        image.SetOrigin(0.0, 0.0, 0.0)
        flat = vol.reshape(-1)  # C order of (z, y, x) = VTK's point order (x fastest)
        scalars = numpy_to_vtk(flat, deep=False, array_type=VTK_UNSIGNED_CHAR)
        scalars.SetName("v")
        image.GetPointData().SetScalars(scalars)
        sample = 0.8 * float(sp.min())
        rw = None
        for mode in ("dvr", "mip"):
            mapper = vtkGPUVolumeRayCastMapper()
            mapper.SetInputData(image)
            mapper.SetAutoAdjustSampleDistances(0)
            mapper.SetSampleDistance(sample)
            mapper.SetImageSampleDistance(1.0)
            ctf = vtkColorTransferFunction()
            ctf.AddRGBPoint(0, 0, 0, 0); ctf.AddRGBPoint(255, 1, 1, 1)
            otf = vtkPiecewiseFunction()
            if mode == "dvr":
                mapper.SetBlendModeToComposite(); method = "composite"
                otf.AddPoint(0, 0.0); otf.AddPoint(255, 1.0)
            else:
                mapper.SetBlendModeToMaximumIntensity(); method = "maximum_intensity"
                otf.AddPoint(0, 1.0); otf.AddPoint(255, 1.0)
            prop = vtkVolumeProperty()
            prop.SetColor(ctf); prop.SetScalarOpacity(otf)
            prop.SetInterpolationTypeToLinear(); prop.ShadeOff()
            prop.SetScalarOpacityUnitDistance(sample)  # per-sample alpha = the ramp, as in vispy
            actor = vtkVolume(); actor.SetMapper(mapper); actor.SetProperty(prop)
            ren = vtkRenderer(); ren.SetBackground(0, 0, 0); ren.AddVolume(actor)
            rw = vtkRenderWindow()
            rw.SetOffScreenRendering(1); rw.SetMultiSamples(0); rw.SetSize(W, H); rw.AddRenderer(ren)
            cam = ren.GetActiveCamera()
            cam.SetViewAngle(FOV); cam.SetFocalPoint(*center)
            cam.SetClippingRange(max(dist - 1.2 * radius, 1e-3 * dist), dist + 1.2 * radius)

            def place(az):
                cam.SetPosition(*eye(az)); cam.SetViewUp(0, 0, 1)

            buf = vtkUnsignedCharArray()

            def grab():
                rw.GetRGBACharPixelData(0, 0, W - 1, H - 1, 1, buf)
                return buf

            place(AZ0)
            rw.Render()
            grab()
            from vtkmodules.util.numpy_support import vtk_to_numpy
            img = vtk_to_numpy(buf).reshape(H, W, 4)[::-1].copy()  # GL rows are bottom-up
            caps = rw.ReportCapabilities() or ""
            glr = next((l.split(":", 1)[1].strip() for l in caps.splitlines() if "renderer string" in l), "?")
            print(f"# vtk {version} window {rw.GetClassName()} renderer {glr} mapper "
                  f"{mapper.GetClassName()}", flush=True)
            ts = []
            for i in range(frames):
                place(AZ0 + (i + 1) * step_deg)
                t = time.perf_counter(); rw.Render(); grab(); ts.append(time.perf_counter() - t)
            place(AZ0); rw.Render(); rw.WaitForCompletion()
            t = time.perf_counter()
            for i in range(frames):
                place(AZ0 + (i + 1) * step_deg)
                rw.Render()
            rw.WaitForCompletion(); batch = time.perf_counter() - t
            report(mode, method, ts, batch, img,
                   dict(version=f"vtk {version}", renderer=f"{glr} ({rw.GetClassName()})",
                        settings=f"vtkGPUVolumeRayCastMapper, texture u8, sample distance {sample:g}, "
                                 f"no auto-adjust, no multisampling"))
            rw.Finalize()

    # ------------------------------------------------------------------ voxscope
    def run_voxscope():
        import voxscope
        kind = os.environ.get("VOXSCOPE_RENDERER", "bricks")
        spacing = tuple(float(s) for s in spacing_zyx)
        # vispy's azimuth a puts the eye where voxscope's 180 - a does (see the docstring).
        def azimuth(az):
            return 180.0 - az
        for mode in ("dvr", "mip"):
            transfer = dict(opacity="gray") if mode == "dvr" else dict(mode="mip")
            r = voxscope.Renderer(vol, spacing=spacing, renderer=kind, size=(W, H), window=(0, 255),
                                  shading=False, elevation=EL, distance=DIST_R, fov=FOV, **transfer)
            img = r.render(azimuth=azimuth(AZ0))  # warm-up: upload, pipelines; the saved image
            ts = []
            for i in range(frames):
                t = time.perf_counter(); r.render(azimuth=azimuth(AZ0 + (i + 1) * step_deg))
                ts.append(time.perf_counter() - t)
            r.draw(azimuth=azimuth(AZ0)); r.finish()
            calls = []
            t = time.perf_counter()
            for i in range(frames):
                c = time.perf_counter(); r.draw(azimuth=azimuth(AZ0 + (i + 1) * step_deg))
                calls.append(time.perf_counter() - c)
            r.finish(); batch = time.perf_counter() - t
            report(mode, f"{kind} {mode}", ts, batch, img,
                   dict(version=f"voxscope {voxscope.__version__} (Python module)", renderer=r.device,
                        ms_call=round(statistics.mean(calls) * 1e3, 4),
                        ms_call_p95=round(float(np.percentile(calls, 95)) * 1e3, 4),
                        settings=f"Renderer(renderer={kind!r}), opacity gray / mode mip, window 0:255, "
                                 f"unshaded, u8 voxels uploaded once"))

    {"vispy": run_vispy, "pygfx": run_pygfx, "vtk": run_vtk, "voxscope": run_voxscope}[peer]()


def parent_main(peers):
    timeout = float(os.environ.get("PEER_TIMEOUT", "300"))
    for peer in peers:
        env = dict(os.environ, PEER_CHILD=peer)
        t0 = time.perf_counter()
        try:
            p = subprocess.run([sys.executable, os.path.abspath(__file__)] + sys.argv[1:], env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=timeout)
            out, rc = p.stdout, p.returncode
        except subprocess.TimeoutExpired as e:
            out = e.stdout.decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
            rc = f"timeout {timeout:.0f}s"
        for line in out.splitlines():
            if line.startswith("{"):
                print(line, flush=True)
            elif line.strip():
                print(line if line.startswith("#") else f"# {peer}| {line}", flush=True)
        if rc != 0:
            print(f"# {peer} failed (exit {rc}) after {time.perf_counter() - t0:.0f} s", flush=True)
    sheets(OUT, [tag])


def sheets(folder, tags=None):
    """For each volume tag: print how far each peer's image is from the first one of the same mode,
    and write folder/sheet_TAG.png with all images of that tag side by side."""
    import glob
    import re
    try:
        from PIL import Image, ImageDraw
    except Exception as e:
        print(f"# no sheet: {e}")
        return
    order = {(p, m): k for k, (p, m) in enumerate((p, m) for p in ALL_PEERS for m in ("dvr", "mip"))}
    found = {}
    for f in glob.glob(os.path.join(folder, "*_*_*.png")):
        m = re.fullmatch(r"(vispy|pygfx|vtk|voxscope)_(dvr|mip)_(.+)\.png", os.path.basename(f))
        if m and (tags is None or m.group(3) in tags):
            found.setdefault(m.group(3), []).append((order[m.group(1), m.group(2)], m.group(1), m.group(2), f))
    for t, items in sorted(found.items()):
        tiles = [(peer, mode, Image.open(f).convert("RGB")) for _, peer, mode, f in sorted(items)]
        for mode in ("dvr", "mip"):
            group = [(peer, np.asarray(im.convert("L"), dtype=np.float32)) for peer, md, im in tiles if md == mode]
            for peer, g in group[1:]:
                ref_peer, ref = group[0]
                if g.shape == ref.shape:
                    print(f"# image {t} {mode}: {peer} vs {ref_peer}: mean |diff| {np.abs(g - ref).mean():.1f} "
                          f"of 255 (means {g.mean():.1f} vs {ref.mean():.1f})", flush=True)
        tw, th = tiles[0][2].size
        scale = min(1.0, 512 / tw)
        sw, sh = int(tw * scale), int(th * scale)
        cols = min(3, len(tiles))
        sheet = Image.new("RGB", (cols * sw, ((len(tiles) + cols - 1) // cols) * sh), "black")
        draw = ImageDraw.Draw(sheet)
        for k, (peer, mode, im) in enumerate(tiles):
            x, y = (k % cols) * sw, (k // cols) * sh
            sheet.paste(im.resize((sw, sh)), (x, y))
            draw.text((x + 4, y + 4), f"{peer} {mode} {t}", fill=(255, 255, 0))
        sheet.save(os.path.join(folder, f"sheet_{t}.png"))


if __name__ == "__main__":
    if SHEET:
        sheets(sys.argv[2])
    elif os.environ.get("PEER_CHILD"):
        child_main(os.environ["PEER_CHILD"])
    else:
        chosen = [p for p in os.environ.get("PEERS", ",".join(ALL_PEERS)).split(",") if p]
        bad = [p for p in chosen if p not in ALL_PEERS]
        if bad:
            raise SystemExit(f"unknown peers {bad}; choose from {ALL_PEERS}")
        parent_main(chosen)
