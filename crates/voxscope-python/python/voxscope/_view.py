"""`view()`: the voxscope app on an array, a Volume or a path, in a child process, so the
interpreter (a notebook, a script, a REPL) goes on at once, on Linux, macOS and Windows alike.

An array is written once to a temporary NRRD file (its channels and time points as NRRD's
`list` and `time` axes) that the app opens; the child removes it when the app closes.
"""

import os
import subprocess
import sys
import tempfile
from typing import IO, Optional, Sequence, Union

import numpy as np

from . import _voxscope

_NRRD_TYPES = {
    "uint8": "uint8",
    "int8": "int8",
    "uint16": "uint16",
    "int16": "int16",
    "uint32": "uint32",
    "int32": "int32",
    "float32": "float",
    "float64": "double",
}


class Viewer:
    """The app window `view()` opened: a child process of this interpreter.

    It runs on its own: closing the window ends it; `close()` ends it from here, `wait()`
    waits for it. `process` is its `subprocess.Popen`.
    """

    def __init__(self, process: subprocess.Popen, source: str, log: Optional[IO] = None):
        self.process = process
        self.source = source
        self._log = log

    @property
    def running(self) -> bool:
        """Whether the app is still open."""
        return self.process.poll() is None

    def wait(self, timeout: Optional[float] = None) -> int:
        """Waits until the app's window is closed (at most `timeout` seconds, else
        `subprocess.TimeoutExpired`); returns its exit status (0: closed normally)."""
        status = self.process.wait(timeout)
        self._close_log()
        return status

    def close(self, timeout: float = 10.0) -> int:
        """Ends the app (terminate, then kill after `timeout` seconds); returns its status."""
        if self.running:
            self.process.terminate()
            try:
                self.process.wait(timeout)
            except subprocess.TimeoutExpired:
                self.process.kill()
        status = self.process.wait()
        self._close_log()
        return status

    def _close_log(self) -> None:
        if self._log is not None:
            self._log.close()
            self._log = None

    def __repr__(self) -> str:
        state = "open" if self.running else f"closed ({self.process.returncode})"
        return f"<voxscope.Viewer of {self.source!r}: pid {self.process.pid}, {state}>"


def _write_nrrd(path: str, data, spacing, channel_axis: Optional[int]) -> None:
    """Writes `data` ((z, y, x) with channels and time as leading axes) as a raw NRRD file."""
    array = np.asarray(_voxscope._voxels(data))
    if array.ndim not in (3, 4, 5):
        raise ValueError(
            f"an array of {array.ndim} dimensions is not a volume: voxscope draws (z, y, x) "
            "arrays, with channels and time as leading axes"
        )
    leading = array.ndim - 3
    if channel_axis is not None and channel_axis < 0:
        channel_axis += array.ndim
    if channel_axis is not None and not 0 <= channel_axis < leading:
        raise ValueError(f"channel_axis={channel_axis} is not a leading axis of a {array.ndim}-D array")
    kinds = ["list" if axis == channel_axis else "time" for axis in range(leading)]
    if kinds.count("time") > 1:
        raise ValueError(f"a {array.ndim}-D array needs channel_axis= (0 or 1): the other leading axis is time")
    if spacing is None:
        spacing = (1.0, 1.0, 1.0)
    elif np.ndim(spacing) == 0:
        spacing = (float(spacing),) * 3
    sz, sy, sx = (float(s) for s in spacing)
    little = np.ascontiguousarray(array, dtype=array.dtype.newbyteorder("<"))
    header = [
        "NRRD0004",
        f"type: {_NRRD_TYPES[array.dtype.name]}",
        f"dimension: {array.ndim}",
        "sizes: " + " ".join(str(n) for n in array.shape[::-1]),
        "kinds: domain domain domain" + "".join(f" {k}" for k in kinds[::-1]),
        f"spacings: {sx!r} {sy!r} {sz!r}" + " nan" * leading,
        "encoding: raw",
        "endian: little",
    ]
    with open(path, "wb") as file:
        file.write(("\n".join(header) + "\n\n").encode("ascii"))
        little.tofile(file)


def view(
    data,
    *,
    spacing: Union[float, Sequence[float], None] = None,
    channel_axis: Optional[int] = None,
    name: str = "array",
    clip_box=None,
    clip_plane=None,
    log: Union[str, "os.PathLike[str]", None] = None,
) -> Viewer:
    """Opens the voxscope app on `data` and returns at once.

    data: a numpy array (z, y, x) (channels and time as leading axes: `channel_axis=` as for
        `render`, the other leading axis is time; the app's channel and time controls pick
        them), a `voxscope.Volume`, or a path or URL the app opens.
    spacing: an array's voxel size (sz, sy, sx), or one number; default 1.
    name: an array's name in the app (the temporary file's).
    clip_box, clip_plane: the app's starting crop box and clip plane, as for `render`.
    log: a file for the app's messages (default: this process's stderr).

    The app runs in a child process (`python -m voxscope._app`) that this interpreter does not
    wait for; the returned Viewer can `wait()` for it or `close()` it.
    """
    words = _voxscope._command_line_words(clip_box=clip_box, clip_plane=clip_plane)
    folder = None
    if isinstance(data, (str, os.PathLike)):
        source = os.fspath(data)
    elif isinstance(data, _voxscope.Volume) and not any(
        word.startswith(("--raw", "--spacing")) for word in data.options
    ):
        source = data.source
    else:
        if isinstance(data, _voxscope.Volume):
            sz, sy, sx = data.spacing
            data, spacing = data.read(), (sz, sy, sx)
        folder = tempfile.mkdtemp(prefix="voxscope-view-")
        safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in name) or "array"
        source = os.path.join(folder, f"{safe}.nrrd")
        try:
            _write_nrrd(source, data, spacing, channel_axis)
        except BaseException:
            import shutil

            shutil.rmtree(folder, ignore_errors=True)
            raise
    command = [sys.executable, "-m", "voxscope._app"]
    if folder is not None:
        command += ["--remove", folder]
    command += ["--", source, *words]
    output = open(log, "ab") if log is not None else None
    options = {}
    if os.name == "nt":
        options["creationflags"] = subprocess.CREATE_NEW_PROCESS_GROUP
    else:
        # Its own session: Ctrl+C in this terminal does not close the window.
        options["start_new_session"] = True
    process = subprocess.Popen(
        command, stdin=subprocess.DEVNULL, stdout=output, stderr=output, **options
    )
    return Viewer(process, source, output)
