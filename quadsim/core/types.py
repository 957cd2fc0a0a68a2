"""Typed messages passed between drivers, the command gate, controllers and physics."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import NamedTuple

from quadsim.core.kinematics import clamp, yaw_of
from quadsim.errors import ConfigError


class ZMode(enum.Enum):
    """How `linear.z` of a Twist is read (docs/reference/command-semantics.md)."""

    VELOCITY = "velocity"  # climb rate, m/s
    HEIGHT = "height"  # altitude wanted = 2.0 + linear.z, m (the original V-REP semantics)


#: Altitude the `height` z-mode adds `linear.z` to, as in the original V-REP script.
HEIGHT_MODE_BASE_M = 2.0


class Twist(NamedTuple):
    """A geometry_msgs/Twist: linear velocity (m/s) in the heading frame and angular rate (rad/s).

    `angular_x` and `angular_y` are carried (the ROS message has them) but ignored.
    """

    linear_x: float = 0.0
    linear_y: float = 0.0
    linear_z: float = 0.0
    angular_x: float = 0.0
    angular_y: float = 0.0
    angular_z: float = 0.0

    def is_finite(self) -> bool:
        """True when no field is NaN or infinite (the gate rejects such commands)."""
        return all(math.isfinite(v) for v in self)


class ActiveCommand(NamedTuple):
    """What the controller acts on at one control step, as decided by the command gate.

    `armed` is False before the first command ever arrives (rotors idle on the ground).
    `hold` is True when the dead-man timeout has expired: hold position, whatever `twist` says.
    `twist` is already clamped to the vehicle's limits.
    """

    twist: Twist
    z_mode: ZMode
    armed: bool
    hold: bool


class ImuReading(NamedTuple):
    """An IMU sample: body rates (rad/s) and specific force (m/s^2), in base_link, noise included."""

    angular_velocity_body_rps: tuple[float, float, float]
    specific_force_body_mps2: tuple[float, float, float]


class VehicleState(NamedTuple):
    """Rigid-body state of the vehicle at one simulation step (REP 103 frames, SI units).

    position_m: base_link origin in `world`. orientation_xyzw: world <- base_link quaternion.
    linear_velocity_mps: in `world`. angular_velocity_body_rps: body rates in `base_link`.
    rotor_thrusts_n: the forces the N rotors (rotor_1..rotor_N) produced during the last physics step.
    specific_force_body_mps2: what an accelerometer at the base reads (acceleration minus
    gravity, in base_link; +9.81 along z at rest), over the last physics step.
    wind_mps: the wind at the vehicle over the last physics step, in `world` (None: no wind).
    imu: what the IMU measured, with its noise (None: no IMU noise; the true values stand).
    """

    step: int
    position_m: tuple[float, float, float]
    orientation_xyzw: tuple[float, float, float, float]
    linear_velocity_mps: tuple[float, float, float]
    angular_velocity_body_rps: tuple[float, float, float]
    rotor_thrusts_n: tuple[float, ...]
    specific_force_body_mps2: tuple[float, float, float]
    wind_mps: tuple[float, float, float] | None = None
    imu: ImuReading | None = None

    def yaw_rad(self) -> float:
        """Heading: rotation about world z, counter-clockwise from world x, in (-pi, pi]."""
        return yaw_of(self.orientation_xyzw)

    def roll_pitch_rad(self) -> tuple[float, float]:
        """Roll and pitch of the ZYX Euler angles (rad)."""
        x, y, z, w = self.orientation_xyzw
        roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
        pitch = math.asin(clamp(2.0 * (w * y - z * x), -1.0, 1.0))
        return roll, pitch


#: One force per rotor, N, in the vehicle's rotor order (rotor_1..rotor_N).
RotorForces = tuple[float, ...]

#: how far from the world's origin a run may start (m, and rad for the heading: any angle fits)
MAX_START_OFFSET_M = 10_000.0


@dataclass(frozen=True)
class StartPose:
    """Where a run starts: on the ground at (x, y), facing yaw (world frame, m and rad); each a
    finite number within MAX_START_OFFSET_M (ConfigError otherwise)."""

    x_m: float = 0.0
    y_m: float = 0.0
    yaw_rad: float = 0.0

    def __post_init__(self) -> None:
        for name in ("x_m", "y_m", "yaw_rad"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ConfigError(f"start pose {name} must be a finite number, got {value!r}")
            if abs(value) > MAX_START_OFFSET_M:
                raise ConfigError(f"start pose {name} = {value:g} is beyond {MAX_START_OFFSET_M:g} from the origin")


class LidarMode(enum.Enum):
    """Which scan a run's LiDAR makes (quadsim.sensors.lidar): one ring (sensor_msgs/LaserScan)
    or all its rings (sensor_msgs/PointCloud2)."""

    PLANAR = "2d"
    SPATIAL = "3d"


class Stepping(enum.Enum):
    """Who steps a vehicle that touches nothing (a run's `physics` setting, recorded with it)."""

    #: quadsim's own copy of PyBullet's step while the vehicle is clear of everything (about twice
    #: as fast), PyBullet's near anything it could touch
    QUADSIM = "quadsim"
    #: PyBullet every step (how runs were flown before quadsim had its own step; for checking)
    PYBULLET = "pybullet"
