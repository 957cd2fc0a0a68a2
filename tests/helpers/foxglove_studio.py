"""A real Foxglove Studio 1.48 for the tests and the docs' pictures: the harness in
../shared/foxglove-studio (the npm @foxglove/studio-base bundle served locally, in Debian's
Chromium) set up once into a cache, served on a free port with files mapped under /data/, and
driven through a person's steps by tests/helpers/foxglove_studio_steps.js."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

import cv2
import numpy as np

from tests.helpers import ROOT

HARNESS = Path(os.environ.get("QUADSIM_FOXGLOVE_STUDIO", ROOT.parent / "shared" / "foxglove-studio"))
STUDIO_DIR = Path.home() / ".cache" / "quadsim-tests" / "foxglove-studio-1.48"
STEPS = Path(__file__).with_name("foxglove_studio_steps.js")


class NoStudio(RuntimeError):
    """What is missing to run Foxglove Studio 1.48 here."""


def studio() -> Path:
    """The folder Foxglove Studio 1.48 is set up in (by its harness, the first time)."""
    if shutil.which("chromium") is None and "CHROMIUM" not in os.environ:
        raise NoStudio("Chromium is needed for Foxglove Studio 1.48 (apt-get install chromium)")
    if shutil.which("node") is None or shutil.which("npm") is None or not (HARNESS / "setup.sh").is_file():
        raise NoStudio(f"node, npm and the Foxglove Studio harness ({HARNESS}) are needed")
    if not (STUDIO_DIR / "node_modules" / "@foxglove" / "studio-base").is_dir():
        done = subprocess.run(["bash", str(HARNESS / "setup.sh"), str(STUDIO_DIR)], capture_output=True, text=True)
        if done.returncode != 0:
            raise NoStudio(f"the harness could not be set up: {done.stderr.strip().splitlines()[-1:]}")
    return STUDIO_DIR


@contextmanager
def served(files: Mapping[str, Path]) -> Iterator[str]:
    """Studio served on a free loopback port with `files` at /data/NAME: its URL."""
    folder = studio()
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = int(s.getsockname()[1])
    mapped = [f"/data/{name}={path}" for name, path in files.items()]
    server = subprocess.Popen(
        ["node", "server.js", str(port), "www", *mapped], cwd=folder, stdout=subprocess.PIPE, text=True
    )
    try:
        assert server.stdout is not None and "serving" in server.stdout.readline()
        yield f"http://127.0.0.1:{port}/"
    finally:
        server.terminate()
        server.wait()


def follow_steps(url: str, log: Path, *steps: str) -> None:
    """A person's steps in Studio at `url` (tests/helpers/foxglove_studio_steps.js says which there are);
    raises with the log's start when one of them could not be carried out."""
    env = {**os.environ, "NODE_PATH": str(studio() / "node_modules")}
    done = subprocess.run(
        ["node", str(STEPS), url, str(log), *steps], env=env, capture_output=True, text=True, timeout=1200
    )
    if done.returncode != 0:
        raise AssertionError(f"a step failed: {(log.read_text() if log.exists() else done.stderr)[:2000]}")


def shot_showing(url: str, log: Path, folder: Path, shows: Callable[[Path], bool], *steps: str) -> Path:
    """A person's `steps`, then screenshots one after another until one `shows` what the test
    waits for (a drawing appears when Studio has loaded and drawn it, later on a busy machine):
    that screenshot. Raises with the log's start when none did (Studio gives up after 300)."""
    folder.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "NODE_PATH": str(studio() / "node_modules")}
    node = subprocess.Popen(
        ["node", str(STEPS), url, str(log), *steps, f"shots-until={folder}"],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        seen = 0
        while True:
            shot = folder / f"shot-{seen}.png"
            if shot.exists():
                seen += 1
                if shows(shot):
                    (folder / "enough").touch()
                    node.wait(timeout=240)
                    return shot
            elif node.poll() is not None:
                if (folder / f"shot-{seen}.png").exists():
                    continue  # the last one, written as it ended
                start = log.read_text()[:2000] if log.exists() else node.stderr.read() if node.stderr else ""
                raise AssertionError(f"{seen} screenshots and none showed it: {start}")
            else:
                time.sleep(0.1)  # polling for the next screenshot, not a moment: nothing is judged by it
    finally:
        node.kill()
        node.wait()


def vehicles_drawn(png: Path, box: tuple[int, int, int, int]) -> int:
    """How many vehicles the screenshot's `box` (left, top, right, bottom) shows: places where the
    red and the blue of the shipped airframes' rotors meet (the default world's red tower and blue
    block stand apart, and the frames' axes are hidden)."""
    image = cv2.imread(str(png))[box[1] : box[3], box[0] : box[2]].astype(int)
    b, g, r = image[..., 0], image[..., 1], image[..., 2]
    red = ((r > 140) & (g < 60) & (b < 60)).astype(np.uint8)
    blue = ((b > 170) & (r < 100) & (g < 140)).astype(np.uint8)
    near = np.ones((41, 41), np.uint8)  # a vehicle's rotors, tens of pixels apart, make one place
    count, labels = cv2.connectedComponents(cv2.dilate(red | blue, near))
    return sum(1 for i in range(1, count) if (red[labels == i].sum() >= 3 and blue[labels == i].sum() >= 3))


def vehicle_names_drawn(png: Path, box: tuple[int, int, int, int]) -> int:
    """How many vehicle names the screenshot's `box` shows: the black boxes, wider than tall, the
    apps draw text markers on (a camera's black housing is smaller and squarer)."""
    image = cv2.imread(str(png))[box[1] : box[3], box[0] : box[2]]
    black = (image.max(axis=2) < 8).astype(np.uint8)
    count, _, stats, _ = cv2.connectedComponentsWithStats(cv2.dilate(black, np.ones((3, 3), np.uint8)))
    width, height = stats[:, cv2.CC_STAT_WIDTH], stats[:, cv2.CC_STAT_HEIGHT]
    return sum(1 for i in range(1, count) if width[i] >= 30 and height[i] >= 10 and width[i] > 1.5 * height[i])
