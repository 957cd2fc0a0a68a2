"""The command gate: the one place where Twist commands are clamped, NaN-checked and timed out.

Every driver's command passes through it, stamped with the step at which it arrived; the
controller only ever sees what the gate decides (an ActiveCommand).
"""

from __future__ import annotations

import logging
import math

from quadsim.core.kinematics import clamp
from quadsim.core.types import HEIGHT_MODE_BASE_M, ActiveCommand, Twist, ZMode
from quadsim.vehicle.params import CommandLimits

log = logging.getLogger(__name__)

_ZERO = Twist()


class CommandGate:
    """Holds the last good command and decides what the controller acts on.

    - Commands are clamped to the vehicle's limits: horizontal speed (as a vector, keeping its
      direction), climb/descent rate or, in height z-mode, the altitude wanted (from the ground
      to max_altitude_m); heading rate.
    - A command with a NaN or infinite field is rejected: the last good command stands and a
      warning is logged once.
    - With no command for longer than `timeout_steps`, `hold` is set (dead-man switch).
    - Before the first command, `armed` is False: the rotors stay idle.
    """

    def __init__(self, limits: CommandLimits, z_mode: ZMode, timeout_steps: int | None) -> None:
        self.limits = limits
        self.z_mode = z_mode
        self.timeout_steps = timeout_steps
        self.rejected_count = 0
        self.clamped_count = 0  # commands taken with a field past the limits (brought within them)
        self._warned = False
        self._twist = _ZERO
        self._last_step: int | None = None

    def reset(self) -> None:
        self._twist = _ZERO
        self._last_step = None

    @property
    def last_command(self) -> Twist:
        return self._twist

    @property
    def last_receive_step(self) -> int | None:
        return self._last_step

    def receive(self, twist: Twist, step: int) -> Twist | None:
        """Take a command that arrived at `step`. Returns it as clamped, or None if rejected."""
        if not twist.is_finite():
            self.rejected_count += 1
            if not self._warned:
                log.warning("rejected a command with a NaN or infinite field (%s); keeping the last good one", twist)
                self._warned = True
            return None
        self._twist = self.clamp(twist)
        if self._twist != twist:
            self.clamped_count += 1
        self._last_step = step
        return self._twist

    def clamp(self, twist: Twist) -> Twist:
        lim = self.limits
        vx, vy = twist.linear_x, twist.linear_y
        speed = math.hypot(vx, vy)
        if speed > lim.max_horizontal_speed_mps:
            if math.isinf(speed):  # both near the float limit: scale down first, keep the direction
                big = max(abs(vx), abs(vy))
                vx, vy = vx / big, vy / big
                speed = math.hypot(vx, vy)
            k = lim.max_horizontal_speed_mps / speed
            vx, vy = vx * k, vy * k
        if self.z_mode is ZMode.VELOCITY:
            vz = clamp(twist.linear_z, -lim.max_descent_rate_mps, lim.max_climb_rate_mps)
        else:
            # down to the ground: an altitude wanted below min_altitude_m lands (control/landing.py)
            vz = clamp(twist.linear_z, -HEIGHT_MODE_BASE_M, lim.max_altitude_m - HEIGHT_MODE_BASE_M)
        wz = clamp(twist.angular_z, -lim.max_yaw_rate_radps, lim.max_yaw_rate_radps)
        return twist._replace(linear_x=vx, linear_y=vy, linear_z=vz, angular_z=wz)

    def set_z_mode(self, z_mode: ZMode) -> None:
        """Switch how linear.z is read; the standing command is re-clamped under the new mode."""
        self.z_mode = z_mode
        self._twist = self.clamp(self._twist)

    def active(self, step: int) -> ActiveCommand:
        """What the controller should act on at `step`."""
        last = self._last_step
        if last is None:
            return ActiveCommand(_ZERO, self.z_mode, False, False)
        timeout = self.timeout_steps
        hold = timeout is not None and step - last > timeout
        return ActiveCommand(self._twist, self.z_mode, True, hold)
