"""`voxscope.view` opens the app in a child process and returns at once: under an Xvfb server
this test starts, the window draws the array (photographed with ImageMagick's `import`),
closes cleanly on Ctrl+Q (xdotool), and the temporary file the array went to is removed.
Needs Xvfb, xdotool and ImageMagick (.ci/run installs them); fails without them."""

import os
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import voxscope


@pytest.fixture
def display(tmp_path, monkeypatch):
    """An Xvfb server of its own (stopped after), DISPLAY set to it, and a private HOME so
    the app neither reads nor writes the user's settings."""
    read, write = os.pipe()
    server = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write), "-screen", "0", "1280x800x24", "-nolisten", "tcp"],
        pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    os.close(write)
    number = b""
    while not number.endswith(b"\n"):
        chunk = os.read(read, 16)
        assert chunk, "Xvfb did not start"
        number += chunk
    os.close(read)
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("DISPLAY", f":{int(number)}")
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(home / ".config"))
    monkeypatch.setenv("XDG_DATA_HOME", str(home / ".local" / "share"))
    yield f":{int(number)}"
    server.terminate()
    server.wait(10)


def screenshot(path: Path) -> np.ndarray:
    subprocess.run(["import", "-window", "root", str(path)], check=True, timeout=60)
    return np.asarray(Image.open(path).convert("RGB"))


def test_view_returns_at_once_and_the_app_draws_the_array(display, tmp_path, head, images):
    voxels, spacing = head
    log = tmp_path / "app.log"
    started = time.monotonic()
    viewer = voxscope.view(voxels, spacing=spacing, name="head", log=log)
    returned = time.monotonic() - started
    try:
        assert returned < 5, f"view() took {returned:.1f} s to return"
        assert viewer.running
        folder = Path(viewer.source).parent
        assert Path(viewer.source).name == "head.nrrd" and folder.exists()
        # The app says when it first drew; a software GPU under load may take minutes.
        deadline = time.monotonic() + 300
        while "voxscope: drew" not in log.read_text(errors="replace"):
            assert viewer.running, f"the app ended:\n{log.read_text(errors='replace')}"
            assert time.monotonic() < deadline, f"the app never drew:\n{log.read_text(errors='replace')}"
            time.sleep(0.5)
        # Photograph until the middle of the screen is lit (the first present may lag).
        for _ in range(60):
            shot = screenshot(tmp_path / "screen.png")
            h, w = shot.shape[:2]
            middle = shot[h // 2 - 100 : h // 2 + 100, w // 2 - 100 : w // 2 + 100]
            if middle.mean() > 0.05 * 255:
                break
            time.sleep(0.5)
        Image.fromarray(shot).save(images / "view_under_xvfb.png")
        assert middle.mean() > 0.05 * 255, "the view is blank in the middle"
        window = subprocess.run(
            ["xdotool", "search", "--sync", "--name", "^voxscope"], capture_output=True, text=True, timeout=60
        ).stdout.split()[0]
        subprocess.run(
            ["xdotool", "windowfocus", "--sync", window, "key", "--clearmodifiers", "ctrl+q"], check=True, timeout=60
        )
        assert viewer.wait(timeout=60) == 0
        assert not folder.exists(), "the temporary file outlived the app"
    finally:
        if viewer.running:
            viewer.close()


def test_view_refuses_a_bad_option_before_it_starts_anything(tmp_path):
    before = set(Path(os.environ.get("TMPDIR", "/tmp")).glob("voxscope-view-*"))
    with pytest.raises(ValueError, match="needs 0 ≤ LOW < HIGH ≤ 1"):
        voxscope.view(np.zeros((4, 4, 4), np.uint8), clip_box=((0, 1), (0, 1), (0.7, 0.2)))
    assert set(Path(os.environ.get("TMPDIR", "/tmp")).glob("voxscope-view-*")) == before
