"""The documentation's pictures, made from the simulator itself. Run from the clone:
`python tools/make_doc_pictures.py [cameras|window|fleet|fleet_window|foxglove|foxglove_scans]`; tests/unit/test_docs.py checks each
is there and shows what it should.

- docs/img/cameras.png: what the two onboard cameras see a few seconds into a flight toward the
  red tower, side by side;
- docs/img/window.png: the real replay window (SDL's x11 driver in an Xvfb of its own, grabbed
  from the X server) playing a recorded square flight: cameras, map with the track, HUD, timeline;
- docs/img/fleet.png: `replay --plot` of the example fleet's recording (examples/fleet.toml), the
  Crazyflie's figure eight in red among the other vehicles' tracks;
- docs/img/fleet_window.png: the real `fly --fleet` window under Xvfb, alpha climbed with a real W
  key press (xdotool); its front camera sees bravo and charlie flying ahead; the fleet on the map.
- docs/img/foxglove_fleet.png and foxglove_live.png: a real Foxglove Studio 1.48 (the harness in
  ../shared/foxglove-studio, tests/helpers/foxglove_studio.py) following docs/foxglove.md's steps: the
  example fleet's recording opened and its `quadsim layout` imported; then the fleet flown live
  with delta on Foxglove, connected, its layout imported and delta climbing on its Teleop panel.
- docs/img/foxglove_scans.png: the same steps on a fleet of two that climbed before the red tower,
  alpha with a 2D LiDAR, a range finder and the front camera's depth colour-mapped, bravo with a
  3D LiDAR: the scans in the 3D panel, the colour-mapped depth beside it.

(The sweep plot in docs/sweeps.md is the one the wind example's sweep draws.)
"""

from __future__ import annotations

import os
import select
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from quadsim import CameraMode, Cameras, SimConfig, Simulator, Twist
from quadsim.sensors.camera import default_cameras

ROOT = Path(__file__).resolve().parents[1]
IMG = ROOT / "docs" / "img"
OUT = IMG / "cameras.png"


def cameras() -> None:
    specs = default_cameras(480, 360, 30)
    with Simulator(SimConfig()) as sim:
        cameras = Cameras(sim, specs, mode=CameraMode.SYNC)
        sim.send(Twist(linear_z=1.0))
        sim.run_for(1.6)  # up to about 1.5 m, facing the red tower 6 m ahead
        sim.send(Twist(linear_x=1.0))
        sim.run_for(1.5)  # toward it
        sim.send(Twist())
        sim.run_for(1.0)
        frames = [cameras.latest(spec.name) for spec in specs]
        cameras.close()
    images = [cv2.cvtColor(f.rgb, cv2.COLOR_RGB2BGR) for f in frames if f is not None]
    gap = np.full((images[0].shape[0], 8, 3), 255, np.uint8)
    cv2.imwrite(str(OUT), np.hstack([images[0], gap, images[1]]))
    print(f"wrote {OUT}")


def _quadsim(*args: str, env: dict[str, str] | None = None) -> subprocess.Popen[bytes]:
    return subprocess.Popen([sys.executable, str(ROOT / "main.py"), *args], cwd=ROOT, env=env)


def _xvfb() -> tuple[subprocess.Popen[bytes], str]:
    read_fd, write_fd = os.pipe()
    xvfb = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write_fd), "-screen", "0", "1280x800x24", "-nolisten", "tcp"],
        pass_fds=(write_fd,),
        stderr=subprocess.DEVNULL,
    )
    os.close(write_fd)
    number = b""
    while not number.endswith(b"\n"):
        if not select.select([read_fd], [], [], 20)[0]:
            raise SystemExit("Xvfb did not start")
        number += os.read(read_fd, 16)
    os.close(read_fd)
    return xvfb, f":{int(number)}"


def window() -> None:
    from PIL import ImageGrab  # Pillow comes with matplotlib (the plot extra)

    if shutil.which("Xvfb") is None:
        raise SystemExit("window.png needs Xvfb (apt-get install xvfb)")
    with tempfile.TemporaryDirectory() as tmp:
        flight = Path(tmp) / "square.mcap"
        made = _quadsim(
            "run", "--script", "square", "--duration", "14", "--camera-size", "480x360", "--out", str(flight)
        )
        if made.wait() != 0:
            raise SystemExit("the flight to show could not be recorded")
        xvfb, display = _xvfb()
        env = {**os.environ, "DISPLAY": display, "SDL_AUDIODRIVER": "dummy"}
        env.pop("SDL_VIDEODRIVER", None)
        replay = _quadsim("replay", str(flight), "--window", "1280x800", env=env)
        try:
            time.sleep(12.0)  # the window up and the flight 9 s in: the second side of the square
            shot = ImageGrab.grab(xdisplay=display)
        finally:
            replay.terminate()
            replay.wait()
            xvfb.terminate()
            xvfb.wait()
    out = IMG / "window.png"
    shot.save(out)
    print(f"wrote {out}")


def fleet() -> None:
    out = IMG / "fleet.png"
    with tempfile.TemporaryDirectory(prefix="quadsim-doc-") as tmp:
        recording = Path(tmp) / "fleet.mcap"
        main_py = [sys.executable, str(ROOT / "main.py")]
        subprocess.run(
            [*main_py, "run", "--fleet", str(ROOT / "examples" / "fleet.toml"), "--out", str(recording)],
            check=True,
            capture_output=True,
        )
        out.unlink(missing_ok=True)
        subprocess.run(
            [*main_py, "replay", str(recording), "--vehicle", "charlie", "--plot", str(out)],
            check=True,
            capture_output=True,
        )
    print(f"wrote {out}")


FLEET_WINDOW = """
[[vehicle]]
name = "alpha"
start = [0.0, 0.0, 0.0, 0.0]
input = "keyboard"
cameras = ["front", "floor"]

[[vehicle]]
name = "bravo"
airframe = "hexa"
start = [4.0, 2.0, 0.0, 180.0]
input = "script:yaw"

[[vehicle]]
name = "charlie"
start = [3.0, -3.0, 0.0, 0.0]
input = "script:figure8"
"""


def fleet_window() -> None:
    from PIL import ImageGrab

    if shutil.which("Xvfb") is None or shutil.which("xdotool") is None:
        raise SystemExit("fleet_window.png needs Xvfb and xdotool (apt-get install xvfb xdotool)")
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "fleet.toml").write_text(FLEET_WINDOW)
        xvfb, display = _xvfb()
        env = {**os.environ, "DISPLAY": display, "SDL_AUDIODRIVER": "dummy"}
        env.pop("SDL_VIDEODRIVER", None)
        fly = _quadsim("fly", "--fleet", str(Path(tmp) / "fleet.toml"), "--window", "1280x800", "--out", tmp, env=env)
        try:
            window = ""
            for _ in range(60):  # by pid: xdotool's --name does not match SDL's window names
                time.sleep(0.5)
                found = subprocess.run(
                    ["xdotool", "search", "--onlyvisible", "--pid", str(fly.pid)],
                    env=env,
                    capture_output=True,
                    text=True,
                ).stdout.split()
                if found:
                    window = found[0]
                    break
            if not window:
                raise SystemExit("the fleet window did not open")
            xdo = ["xdotool", "windowfocus", "--sync", window]
            subprocess.run(xdo, env=env, capture_output=True)
            subprocess.run(["xdotool", "keydown", "w"], env=env, check=True)
            time.sleep(2.5)  # climb
            subprocess.run(["xdotool", "keyup", "w"], env=env, check=True)
            time.sleep(7.0)  # bravo turning on the spot ahead, charlie on its figure eight
            shot = ImageGrab.grab(xdisplay=display)
            subprocess.run(["xdotool", "key", "Escape"], env=env, check=True)
            fly.wait(timeout=30)
        finally:
            fly.kill()
            xvfb.terminate()
            xvfb.wait()
    out = IMG / "fleet_window.png"
    shot.save(out)
    print(f"wrote {out}")


def _small_png(shot: Path, out: Path) -> None:
    """A screenshot as a docs picture: 1200 pixels wide, 128 colours."""
    from PIL import Image

    with Image.open(shot) as image:
        small = image.convert("RGB").resize((1200, 750), Image.Resampling.LANCZOS)
        small.quantize(128, dither=Image.Dither.NONE).save(out, optimize=True)
    print(f"wrote {out}")


def foxglove() -> None:
    sys.path.insert(0, str(ROOT))
    from tests.helpers import foxglove_studio

    main_py = [sys.executable, str(ROOT / "main.py")]
    example = ROOT / "examples" / "fleet.toml"
    with tempfile.TemporaryDirectory(prefix="quadsim-doc-") as folder:
        tmp = Path(folder)
        recording, live = tmp / "fleet.mcap", tmp / "live_fleet.toml"
        run = [*main_py, "run", "--fleet", str(example), "--duration", "8", "--out", str(recording)]
        subprocess.run(run, check=True, capture_output=True)
        subprocess.run([*main_py, "layout", str(recording)], check=True, capture_output=True)
        live.write_text(example.read_text().replace('input = "idle"', 'input = "foxglove"'))
        subprocess.run([*main_py, "layout", str(live)], check=True, capture_output=True)
        files = {p.name: p for p in (recording, tmp / "fleet.layout.json", tmp / "live_fleet.layout.json")}
        with foxglove_studio.served(files) as url:
            steps = ["open-file=/data/fleet.mcap", "wait=5", "import-layout=/data/fleet.layout.json"]
            steps += ["sidebar=layouts", "seek=0.75", "wait=8", f"shot={tmp / 'recording.png'}"]
            foxglove_studio.follow_steps(url, tmp / "recording.log", *steps)
            with socket.socket() as s:
                s.bind(("127.0.0.1", 0))
                port = s.getsockname()[1]
            flying = _quadsim("run", "--fleet", str(live), "--foxglove", f"127.0.0.1:{port}", "--out", str(tmp))
            try:
                time.sleep(8.0)  # the server up and the scripted vehicles climbing
                steps = [f"connect=ws://127.0.0.1:{port}", "wait=5", "import-layout=/data/live_fleet.layout.json"]
                steps += ["sidebar=layouts", "wait=3", "hold=4,3000", "wait=3", f"shot={tmp / 'live.png'}"]
                foxglove_studio.follow_steps(url, tmp / "live.log", *steps)
            finally:
                flying.send_signal(signal.SIGINT)
                flying.wait(timeout=60)
        _small_png(tmp / "recording.png", IMG / "foxglove_fleet.png")
        _small_png(tmp / "live.png", IMG / "foxglove_live.png")


def foxglove_scans() -> None:
    sys.path.insert(0, str(ROOT))
    from PIL import Image

    from tests.helpers import foxglove_studio
    from tests.helpers.fleets import SCANS_FLEET

    main_py = [sys.executable, str(ROOT / "main.py")]
    with tempfile.TemporaryDirectory(prefix="quadsim-doc-") as folder:
        tmp = Path(folder)
        (tmp / "scans.toml").write_text(SCANS_FLEET)
        run = [*main_py, "run", "--fleet", str(tmp / "scans.toml"), "--duration", "4", "--out", str(tmp / "scans.mcap")]
        subprocess.run(run, check=True, capture_output=True)
        subprocess.run([*main_py, "layout", str(tmp / "scans.mcap")], check=True, capture_output=True)
        files = {p.name: p for p in (tmp / "scans.mcap", tmp / "scans.layout.json")}
        with foxglove_studio.served(files) as url:
            steps = ["open-file=/data/scans.mcap", "wait=5", "import-layout=/data/scans.layout.json"]
            steps += ["sidebar=layouts", "seek=0.9", "wait=8", f"shot={tmp / 'scans.png'}"]
            foxglove_studio.follow_steps(url, tmp / "scans.log", *steps)
        with Image.open(tmp / "scans.png") as image:  # the 3D panel, the camera and its depth
            small = image.convert("RGB").crop((50, 30, 1600, 462)).resize((1200, 334), Image.Resampling.LANCZOS)
            small.quantize(128, dither=Image.Dither.NONE).save(IMG / "foxglove_scans.png", optimize=True)
        print(f"wrote {IMG / 'foxglove_scans.png'}")


PICTURES = {"cameras": cameras, "window": window, "fleet": fleet, "fleet_window": fleet_window, "foxglove": foxglove}
PICTURES["foxglove_scans"] = foxglove_scans


def main(names: list[str]) -> None:
    IMG.mkdir(parents=True, exist_ok=True)
    for name in names or list(PICTURES):
        if name not in PICTURES:
            raise SystemExit(f"no picture {name!r}: {', '.join(PICTURES)}")
        PICTURES[name]()


if __name__ == "__main__":
    main(sys.argv[1:])
