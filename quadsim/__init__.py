"""quadsim: a quadrotor teleop simulator (PyBullet physics, Twist commands, MCAP recordings).

The public API, loaded on first use so that `import quadsim` stays light (no pybullet, no pygame):

    from quadsim import Simulator, SimConfig, Twist
    with Simulator(SimConfig()) as sim:
        sim.send(Twist(linear_z=1.0))   # climb at 1 m/s
        sim.run_for(2.0)
        print(sim.state.position_m)
"""

# typing.TYPE_CHECKING without importing typing (nor __future__): `import quadsim` runs first of
# all in the `quadsim` command, before quadsim.apps.launch takes SIGINT and SIGTERM, and typing
# would add some 10 ms in which a Ctrl-C meets Python's default handler (a traceback)
TYPE_CHECKING = False

#: the version these sources are: a development release (.devN) until 0.3.0 is released; the docs
#: and the changelog's first heading name it too (tests/unit/test_docs.py)
__version__ = "0.3.0.dev0"

#: public name -> module that defines it
_PUBLIC = {
    "ActiveCommand": "quadsim.core.types",
    "CameraImage": "quadsim.sim.cameras",
    "CameraInfo": "quadsim.sensors.camera",
    "CameraMode": "quadsim.sim.cameras",
    "Cameras": "quadsim.sim.cameras",
    "CameraSpec": "quadsim.sensors.camera",
    "ConfigError": "quadsim.errors",
    "Controller": "quadsim.control",
    "ControllerKind": "quadsim.control",
    "Drone": "quadsim.sim.drone",
    "Fleet": "quadsim.sim.fleet",
    "FleetVehicle": "quadsim.sim.fleet",
    "LidarMode": "quadsim.core.types",
    "QuadsimError": "quadsim.errors",
    "Rates": "quadsim.sim.config",
    "ScriptError": "quadsim.errors",
    "SimConfig": "quadsim.sim.config",
    "Simulator": "quadsim.sim.simulator",
    "StartPose": "quadsim.core.types",
    "StateLog": "quadsim.sim.loop",
    "Turbulence": "quadsim.physics.wind",
    "Twist": "quadsim.core.types",
    "VehicleState": "quadsim.core.types",
    "WindModel": "quadsim.physics.wind",
    "WindSettings": "quadsim.physics.wind",
    "ZMode": "quadsim.core.types",
    "record": "quadsim.session.outputs",
}

__all__ = [
    "ActiveCommand",
    "CameraImage",
    "CameraInfo",
    "CameraMode",
    "CameraSpec",
    "Cameras",
    "ConfigError",
    "Controller",
    "ControllerKind",
    "Drone",
    "Fleet",
    "FleetVehicle",
    "LidarMode",
    "QuadsimError",
    "Rates",
    "ScriptError",
    "SimConfig",
    "Simulator",
    "StartPose",
    "StateLog",
    "Turbulence",
    "Twist",
    "VehicleState",
    "WindModel",
    "WindSettings",
    "ZMode",
    "__version__",
    "record",
]


def __getattr__(name: str) -> "Any":
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module 'quadsim' has no attribute {name!r}")
    from importlib import import_module

    value = getattr(import_module(module), name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_PUBLIC})


if TYPE_CHECKING:  # for type checkers and IDEs: the same names, eagerly
    from typing import Any

    from quadsim.control import Controller, ControllerKind
    from quadsim.core.types import ActiveCommand, LidarMode, StartPose, Twist, VehicleState, ZMode
    from quadsim.errors import ConfigError, QuadsimError, ScriptError
    from quadsim.physics.wind import Turbulence, WindModel, WindSettings
    from quadsim.sensors.camera import CameraInfo, CameraSpec
    from quadsim.session.outputs import record
    from quadsim.sim.cameras import CameraImage, CameraMode, Cameras
    from quadsim.sim.config import Rates, SimConfig
    from quadsim.sim.drone import Drone
    from quadsim.sim.loop import StateLog
    from quadsim.sim.simulator import Simulator
