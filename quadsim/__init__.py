"""quadsim: a quadrotor teleop simulator (PyBullet physics, Twist commands, MCAP recordings)."""

from quadsim.control import ControllerKind
from quadsim.errors import ConfigError, QuadsimError, ScriptError
from quadsim.loop import Rates, StateLog
from quadsim.messages import Twist, VehicleState, ZMode
from quadsim.physics import StartPose
from quadsim.sim import SimConfig, Simulator

__version__ = "0.1.0"

__all__ = [
    "ConfigError", "ControllerKind", "QuadsimError", "Rates", "ScriptError", "SimConfig",
    "Simulator", "StartPose", "StateLog", "Twist", "VehicleState", "ZMode", "__version__",
]
