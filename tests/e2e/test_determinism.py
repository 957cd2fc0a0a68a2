"""Headless runs are deterministic: same inputs, bit-identical states, also across processes.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/unit/test_determinism.py."""

import hashlib
import struct
import subprocess
import sys

from quadsim.apps.flight_quality import fly
from quadsim.physics.wind import Turbulence, WindSettings
from quadsim.sim.config import SimConfig
from tests.helpers import ROOT


def digest(states) -> str:
    h = hashlib.sha256()
    for s in states:
        h.update(struct.pack("<q", s.step))
        for group in (
            s.position_m,
            s.orientation_xyzw,
            s.linear_velocity_mps,
            s.angular_velocity_body_rps,
            s.rotor_thrusts_n,
            s.wind_mps or (),
            *(s.imu or ()),
        ):
            h.update(struct.pack(f"<{len(group)}d", *group))
    return h.hexdigest()


def test_two_processes_give_the_same_states():
    code = (
        f"import sys; sys.path.insert(0, {str(ROOT)!r}); from tests.e2e.test_determinism import digest; "
        "from quadsim.apps.flight_quality import fly; from quadsim.physics.wind import Turbulence, WindSettings; "
        "from quadsim.sim.config import SimConfig; "
        "print(digest(fly('square', config=SimConfig(wind=WindSettings(3.0, 10.0, Turbulence.LIGHT))).states))"
    )
    outs = [
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
        ).stdout.strip()
        for _ in range(2)
    ]
    windy = SimConfig(wind=WindSettings(3.0, 10.0, Turbulence.LIGHT))
    assert outs[0] == outs[1] == digest(fly("square", config=windy).states)
