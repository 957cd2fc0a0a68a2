"""Regenerate tests/recordings/: small recordings (no cameras) of representative flights that
the test suite re-flies. Run it when a change to the flight is intended, and commit the result:

    .venv/bin/python tools/make_regression_recordings.py                 # all of them
    .venv/bin/python tools/make_regression_recordings.py square_cascade  # only those named
"""

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import pygame  # noqa: E402

from quadsim import ControllerKind, FleetVehicle, SimConfig, StartPose, ZMode  # noqa: E402
from quadsim.apps.window.teleop import TeleopApp, TeleopOptions  # noqa: E402
from quadsim.drivers.scripted import ScriptedDriver, load_script  # noqa: E402
from quadsim.physics.wind import Turbulence, WindSettings  # noqa: E402
from quadsim.session.outputs import OutputOptions  # noqa: E402
from quadsim.session.pacing import FixedStepPacer  # noqa: E402
from quadsim.session.plan import RunPlan  # noqa: E402
from quadsim.session.run import fly  # noqa: E402
from quadsim.vehicle.params import SHIPPED_VEHICLES  # noqa: E402

OUT = ROOT / "tests" / "recordings"


def scripted(name: str, controller: ControllerKind, wind: WindSettings = WindSettings(), seed: int = 0) -> Path:
    script = load_script(name)
    windy = f"_{wind.turbulence.value}_wind" if wind.turbulence else ""
    path = OUT / f"{name}{windy}_{controller.value}.mcap"
    path.unlink(missing_ok=True)
    config = SimConfig(controller=controller, z_mode=script.z_mode or ZMode.VELOCITY, wind=wind, seed=seed)
    outputs = OutputOptions(out=path, cameras=())
    info = {"command": "run", "script": name}
    fly(
        RunPlan.alone(
            config, ScriptedDriver(script), duration_s=script.duration_s, outputs=outputs, label=name, run_info=info
        )
    )
    return path


def keyboard_session() -> Path:
    """An interactive session flown with synthetic key events, switching z-mode on the way."""
    path = OUT / "keyboard_session_cascade.mcap"
    path.unlink(missing_ok=True)
    app = TeleopApp(
        SimConfig(),
        OutputOptions(out=path, cameras=()),
        TeleopOptions(input="keyboard"),
        pacer=FixedStepPacer(240, 1 / 30),
    )
    plan = {
        3: (pygame.K_w, True),
        70: (pygame.K_w, False),
        80: (pygame.K_UP, True),
        95: (pygame.K_a, True),
        140: (pygame.K_a, False),
        170: (pygame.K_UP, False),
        180: (pygame.K_TAB, True),
        200: (pygame.K_LEFT, True),
        215: (pygame.K_w, True),
        240: (pygame.K_w, False),
        250: (pygame.K_LEFT, False),
        260: (pygame.K_SPACE, True),
        270: (pygame.K_SPACE, False),
    }

    def events(a: TeleopApp) -> None:
        if a.frame_count in plan:
            key, down = plan[a.frame_count]
            pygame.event.post(
                pygame.event.Event(pygame.KEYDOWN if down else pygame.KEYUP, key=key, mod=0, unicode="", scancode=0)
            )

    app.run(max_frames=330, before_frame=events)
    app.close()
    return path


def fleet_trio() -> Path:
    """A fleet of three in light turbulence: a square (cascade), a turn on the spot (the seed
    controller) and an idle hexacopter, each with its own wind and IMU-noise streams."""
    path = OUT / "fleet_trio_wind.mcap"
    path.unlink(missing_ok=True)
    vehicles = [
        FleetVehicle("alpha", driver=ScriptedDriver(load_script("square"))),
        FleetVehicle(
            "bravo",
            start=StartPose(0.0, 4.0, 1.57),
            controller=ControllerKind.SEED,
            driver=ScriptedDriver(load_script("yaw")),
        ),
        FleetVehicle("charlie", start=StartPose(-4.0, 0.0), urdf=SHIPPED_VEHICLES["hexa"]),
    ]
    config = SimConfig(z_mode=ZMode.HEIGHT, wind=WindSettings(3.0, 45.0, Turbulence.LIGHT), seed=11)
    outputs = OutputOptions(out=path, cameras=())
    fly(RunPlan(config, tuple(vehicles), 10.0, outputs, label="fleet", run_info={"command": "run"}))
    return path


def golden() -> Path:
    """tests/golden/takeoff_cameras.mcap: the one-vehicle flight tests/integration/test_recording_golden.py
    flies again through the command line and compares record for record."""
    import subprocess

    from tests.integration.test_recording_golden import COMMAND, GOLDEN

    GOLDEN.unlink(missing_ok=True)
    # flown by PyBullet's step alone, as the test flies it again (its docstring says why)
    command = [sys.executable, str(ROOT / "main.py"), *COMMAND, "--physics", "pybullet", "--out", str(GOLDEN)]
    subprocess.run(command, check=True)
    return GOLDEN


RECORDINGS = {
    "square_cascade": lambda: scripted("square", ControllerKind.CASCADE),
    "figure8_seed": lambda: scripted("figure8", ControllerKind.SEED),
    "climb_cascade": lambda: scripted("climb", ControllerKind.CASCADE),
    # wind, turbulence and IMU noise re-fly bit for bit from the recorded seed
    "takeoff_moderate_wind_cascade": lambda: scripted(
        "takeoff", ControllerKind.CASCADE, WindSettings(5.0, 90.0, Turbulence.MODERATE), seed=7
    ),
    "keyboard_session_cascade": keyboard_session,
    # a fleet: every vehicle under its name, one clock, each with its own random streams
    "fleet_trio_wind": fleet_trio,
    # tests/golden/: compared record for record, cameras included
    "golden": golden,
}

if __name__ == "__main__":
    # no argument: all of them; or name the ones whose flight changed (e.g. square_cascade)
    wanted = sys.argv[1:] or list(RECORDINGS)
    unknown = [name for name in wanted if name not in RECORDINGS]
    if unknown:
        sys.exit(f"unknown recording {unknown[0]!r}; choose from {', '.join(RECORDINGS)}")
    OUT.mkdir(parents=True, exist_ok=True)
    for name in wanted:
        made = RECORDINGS[name]()
        print(f"{made.relative_to(ROOT)}: {made.stat().st_size / 1e3:.0f} kB")
