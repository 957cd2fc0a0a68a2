"""A controller of your own flying the square: small-angle velocity control in about fifty lines,
written against quadsim's Controller protocol (reset, update, describe), with its gains as data.

    .venv/bin/python examples/own_controller.py              # in a clone; installed: python own_controller.py
    PYTHONPATH=examples .venv/bin/python main.py check own_controller.mcap

It flies the built-in 'square' script, records the flight and prints where it ended. The recording
names the controller's class (own_controller:SmallAngleController); `check` makes it again with
SmallAngleController.from_description(vehicle, details) and re-flies it, when its module is on
the Python path (PYTHONPATH above), or says in one line why it cannot.
"""

from __future__ import annotations

import math
from typing import Any

from quadsim import ActiveCommand, SimConfig, Simulator, VehicleState, ZMode, record
from quadsim.core.types import HEIGHT_MODE_BASE_M
from quadsim.drivers.scripted import ScriptedDriver, load_script
from quadsim.vehicle.mixer import Mixer
from quadsim.vehicle.params import VehicleParams, load_vehicle

#: gains of the three loops, and the steepest tilt it asks for
GAINS = {"velocity_p_per_s": 2.0, "altitude_p_per_s": 1.5, "attitude_p_per_s": 8.0, "rate_p_per_s": 20.0}
MAX_TILT_RAD = 0.35


class SmallAngleController:
    """Velocity error -> tilt wanted (small angles) -> body rate wanted -> torque -> the mixer's
    rotor forces; thrust holds the climb rate (or the altitude, in height z-mode)."""

    def __init__(self, vehicle: VehicleParams, **gains: float) -> None:
        self.vehicle, self.mixer = vehicle, Mixer(vehicle)
        self.gains = {**GAINS, **gains}
        self._idle = (0.0,) * len(vehicle.rotors)

    @classmethod
    def from_description(cls, vehicle: VehicleParams, details: dict[str, Any]) -> SmallAngleController:
        """Made again by `check` from what `describe` recorded."""
        return cls(vehicle, **details["gains"])

    def describe(self) -> dict[str, Any]:
        return {"name": "small_angle", "gains": dict(self.gains)}

    def reset(self) -> None:
        pass  # nothing wound up: no integrators

    def update(self, state: VehicleState, command: ActiveCommand, dt_s: float) -> tuple[float, ...]:
        if not command.armed:
            return self._idle
        k, g, m = self.gains, self.vehicle.gravity_mps2, self.vehicle.mass_kg
        twist = command.twist
        hold = command.hold  # the dead-man timeout: stop where it is
        yaw = state.yaw_rad()
        roll, pitch = state.roll_pitch_rad()
        vx, vy, vz = state.linear_velocity_mps
        # the horizontal velocity wanted, in the heading frame (x forward, y left), and as it is
        forward = 0.0 if hold else twist.linear_x
        left = 0.0 if hold else twist.linear_y
        c, s = math.cos(yaw), math.sin(yaw)
        along, across = c * vx + s * vy, -s * vx + c * vy
        pitch_wanted = max(-MAX_TILT_RAD, min(MAX_TILT_RAD, k["velocity_p_per_s"] * (forward - along) / g))
        roll_wanted = max(-MAX_TILT_RAD, min(MAX_TILT_RAD, -k["velocity_p_per_s"] * (left - across) / g))
        # the climb rate wanted: commanded, or back to the altitude wanted (height z-mode)
        if command.z_mode is ZMode.HEIGHT and not hold:
            climb = k["altitude_p_per_s"] * (HEIGHT_MODE_BASE_M + twist.linear_z - state.position_m[2])
        else:
            climb = 0.0 if hold else twist.linear_z
        thrust = m * (g + k["velocity_p_per_s"] * (climb - vz)) / max(0.5, math.cos(roll) * math.cos(pitch))
        # attitude -> body rates -> torques (the inertia's diagonal: a symmetric airframe)
        p, q, r = state.angular_velocity_body_rps
        rates_wanted = (
            k["attitude_p_per_s"] * (roll_wanted - roll),
            k["attitude_p_per_s"] * (pitch_wanted - pitch),
            0.0 if hold else twist.angular_z,
        )
        inertia = self.vehicle.inertia_kgm2
        torques = [
            inertia[i][i] * k["rate_p_per_s"] * (want - got)
            for i, (want, got) in enumerate(zip(rates_wanted, (p, q, r)))
        ]
        return self.mixer.to_rotor_forces(thrust, *torques)


if __name__ == "__main__":
    from own_controller import SmallAngleController as Importable  # type: ignore[import-not-found]  # its module, not __main__

    script = load_script("square")
    with Simulator(
        SimConfig(z_mode=script.z_mode or ZMode.VELOCITY), ScriptedDriver(script), controller=Importable(load_vehicle())
    ) as sim:
        with record(sim, "own_controller.mcap"):
            sim.run_for(script.duration_s)
        x, y, z = sim.state.position_m
        print(f"flew the square with {Importable.__name__}: ended at x={x:+.2f} y={y:+.2f} z={z:+.2f} m")
        print("recorded to own_controller.mcap")
