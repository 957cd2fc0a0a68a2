"""quadsim: a quadrotor teleop simulator (PyBullet physics, Twist commands, MCAP recordings)."""

import os

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")  # before anything imports pygame

from quadsim.control import ControllerKind  # noqa: E402
from quadsim.errors import ConfigError, QuadsimError, ScriptError  # noqa: E402
from quadsim.loop import Rates, StateLog  # noqa: E402
from quadsim.messages import Twist, VehicleState, ZMode  # noqa: E402
from quadsim.physics import StartPose  # noqa: E402
from quadsim.sim import SimConfig, Simulator  # noqa: E402

__version__ = "0.1.0"

__all__ = [
    "ConfigError", "ControllerKind", "QuadsimError", "Rates", "ScriptError", "SimConfig",
    "Simulator", "StartPose", "StateLog", "Twist", "VehicleState", "ZMode", "__version__",
]
