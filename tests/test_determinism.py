"""Headless runs are deterministic: same inputs, bit-identical states, also across processes."""

import hashlib
import struct
import subprocess
import sys
from pathlib import Path

from quadsim.apps.evaluate import fly
from quadsim.control import ControllerKind

ROOT = Path(__file__).resolve().parent.parent


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
        ):
            h.update(struct.pack(f"<{len(group)}d", *group))
    return h.hexdigest()


def test_same_scenario_twice_is_bit_identical():
    a, b = fly("figure8"), fly("figure8")
    assert len(a.states) == len(b.states) > 1000
    assert a.states == b.states  # exact float equality, field by field


def test_seed_controller_is_deterministic_too():
    assert fly("square", ControllerKind.SEED).states == fly("square", ControllerKind.SEED).states


def test_two_processes_give_the_same_states():
    code = (
        f"import sys; sys.path.insert(0, {str(ROOT)!r}); from tests.test_determinism import digest; "
        "from quadsim.apps.evaluate import fly; print(digest(fly('square').states))"
    )
    outs = [
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
        ).stdout.strip()
        for _ in range(2)
    ]
    assert outs[0] == outs[1] == digest(fly("square").states)
