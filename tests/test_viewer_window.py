"""The viewer in a real window: `yore view` on a virtual X display (Xvfb, Mesa's software
OpenGL), driven by real X mouse and key events (xdotool): D turns draw mode on, a left-button
drag draws a stroke, Z undoes it, S saves a picture, Q closes the window and ends the command.

Every wait polls for what the viewer reports (its log lines, a window) with a generous
deadline; nothing is asserted about how long anything takes."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import yore

pytestmark = pytest.mark.skipif(
    shutil.which("Xvfb") is None or shutil.which("xdotool") is None,
    reason="needs Xvfb and xdotool (make setup installs them)",
)

DEADLINE = 120.0  # s, for each wait: the machine may be busy


def wait_for(condition, what):
    end = time.monotonic() + DEADLINE
    while time.monotonic() < end:
        value = condition()
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError(f"gave up waiting for {what}")


@pytest.fixture
def display():
    read, write = os.pipe()
    server = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write), "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
        pass_fds=(write,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    os.close(write)
    with os.fdopen(read) as stream:
        number = stream.readline().strip()
    try:
        yield f":{number}"
    finally:
        server.terminate()
        server.wait(timeout=30)


def xdotool(display, *arguments):
    return subprocess.run(
        ["xdotool", *arguments],
        env={**os.environ, "DISPLAY": display},
        capture_output=True,
        text=True,
        timeout=60,
    ).stdout.strip()


@pytest.mark.slow
def test_a_mouse_drag_in_the_window_draws_a_stroke_and_z_undoes_it(display, tmp_path):
    scene = Path(yore.__file__).with_name("data") / "hanging.toml"
    log = tmp_path / "view.log"
    with open(log, "w") as output:
        view = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "yore",
                "view",
                str(scene),
                "--set",
                "mesh.nx=13",
                "--set",
                "mesh.ny=13",
                "--width",
                "800",
                "--height",
                "600",
            ],
            cwd=tmp_path,
            stdout=output,
            stderr=subprocess.STDOUT,
            env={**os.environ, "DISPLAY": display},
        )
    try:
        window = wait_for(
            lambda: xdotool(display, "search", "--name", "Polyscope"), "the viewer's window"
        ).split()[0]

        def logged(text):
            return wait_for(lambda: text in log.read_text(), f"{text!r} in the log")

        logged("viewer ready")
        xdotool(display, "mousemove", "--window", window, "200", "300")
        xdotool(display, "key", "--window", window, "d")
        logged("draw mode on")
        # a drag across the cloth's upper part (left of the panel), sample by sample
        xdotool(display, "mousemove", "--window", window, "120", "260")
        xdotool(display, "mousedown", "1")
        logged("drawing a stroke")
        for x in range(150, 400, 25):
            xdotool(display, "mousemove", "--window", window, str(x), "250")
        xdotool(display, "mouseup", "1")
        logged("vertices added")
        xdotool(display, "key", "--window", window, "z")
        logged("stroke undone")
        xdotool(display, "key", "--window", window, "s")
        logged("picture saved")
        xdotool(display, "key", "--window", window, "q")
        assert view.wait(timeout=DEADLINE) == 0, log.read_text()
    finally:
        if view.poll() is None:
            view.kill()
            view.wait()
    text = log.read_text()
    line = next(line for line in text.splitlines() if "vertices added" in line)
    added = int(line.split(",")[-1].split()[0])
    assert added > 10, line  # hanging.toml's stroke options: along growth with refinement
    pictures = list(tmp_path.glob("yore-view-*.png"))
    assert len(pictures) == 1
    with Image.open(pictures[0]) as image:
        assert image.size == (800, 600)
        pixels = np.asarray(image.convert("RGB"))
    assert np.mean(np.any(pixels < 235, axis=2)) > 0.1  # the cloth fills part of the view
