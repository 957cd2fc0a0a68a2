"""Headless runs are deterministic: same inputs, bit-identical states, also across processes.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/unit/test_determinism.py."""

import hashlib
import os
import platform
import struct
import subprocess
import sys

import pytest

from quadsim.apps.flight_quality import fly
from quadsim.physics.wind import Turbulence, WindSettings
from quadsim.sim.config import SimConfig
from tests.helpers import ROOT
from tests.helpers.cli import run_main


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


#: OpenBLAS kernels every x86-64 CPU of the last decade runs (OPENBLAS_CORETYPE picks one): without
#: FMA (Sandybridge) and with it (Haswell); the machine's own choice is the third run
OPENBLAS_KERNELS = ("Sandybridge", "Haswell")


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="OpenBLAS's x86-64 kernels")
def test_a_recording_re_flies_to_the_bit_whichever_kernels_openblas_picks_for_the_cpu():
    """The stored fleet (a quadrotor and a hexarotor, the hexa's mixer a pseudo-inverse, light
    turbulence) re-flies exactly with each kernel: nothing in a flight goes through BLAS or LAPACK,
    whose last bits depend on the CPU (a recording made on one machine re-flew at 1e-15 m on an
    AVX-512 one before the mixer and the turbulence filter were inverted exactly)."""
    recording = ROOT / "tests" / "recordings" / "fleet_trio_wind.mcap"
    for kernel in (None, *OPENBLAS_KERNELS):
        env = dict(os.environ)
        if kernel:
            env["OPENBLAS_CORETYPE"] = kernel
        out = run_main("check", "--tolerance-m", "0", "--tolerance-rad", "0", recording, env=env)
        assert out.returncode == 0 and "flies again identically" in out.stdout, f"{kernel}: {out.stdout}{out.stderr}"
