"""The second airframe preset, a Crazyflie 2.x sized quadrotor (27 g): data files only, flying
the scenarios with gains from its own file. And gains as data in general.

Its integration tests (several layers, in-process or one process started); the others are in tests/unit/test_crazyflie.py."""

import subprocess
import sys

import pytest

from quadsim import ControllerKind, SimConfig, Simulator
from quadsim.errors import ConfigError
from quadsim.vehicle.params import DEFAULT_URDF, load_vehicle
from tests.helpers import ROOT
from tests.unit.test_crazyflie import CF


def test_the_seed_controller_refuses_it_and_its_reference_is_the_original_quads(tmp_path):
    """The seed controller's constants were the original script's, for the original quad: the
    Crazyflie turns 3.8x as fast in roll for its hover thrust, and flew away (18 m off in a take-off).
    Refused in one line, as the hexa is; the reference figures are the shipped quad's own."""
    from quadsim.control.seed import SEED_ROLL_RESPONSE, SEED_YAW_RESPONSE, seed_responses

    roll, yaw = seed_responses(load_vehicle(DEFAULT_URDF))
    assert roll == pytest.approx(SEED_ROLL_RESPONSE, rel=1e-3) and yaw == pytest.approx(SEED_YAW_RESPONSE, rel=3e-3)
    with pytest.raises(ConfigError, match=r"crazyflie.urdf: the seed controller.*roll 3.8x and yaw 5.4x"):
        Simulator(SimConfig(urdf=CF, controller=ControllerKind.SEED))
    args = ["run", "--script", "takeoff", "--vehicle", "crazyflie", "--controller", "seed", "--cameras", "none"]
    done = subprocess.run([sys.executable, str(ROOT / "main.py"), *args], capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 2 and "use the cascade controller" in done.stderr and "Traceback" not in done.stderr
    assert not list(tmp_path.rglob("*.mcap"))  # nothing recorded
