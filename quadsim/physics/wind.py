"""The air the vehicle flies through: a constant wind plus Dryden turbulence, seeded, or a wind
model of the user's own (`WindModel`: the wind at a time and place).

Pure numbers (numpy for the random draws), no pybullet. Physics advances it once per physics
step and the aerodynamic forces act through the airspeed, velocity minus this wind.

Direction convention (settings `--wind SPEED,FROM_DEG`): meteorological, the direction the wind
blows FROM, in degrees clockwise from north, north being world +y and east world +x (REP 103's
ENU world). `3,90` is 3 m/s from the east: the air moves toward -x.

Turbulence: the Dryden model of MIL-F-8785C (and MIL-HDBK-1797), low-altitude form, as RotorPy
offers it. The gust components are along the mean wind (u), across it (v) and vertical (w):
    H_u(s) = sigma_u sqrt(2 L_u / (pi V)) / (1 + (L_u/V) s)
    H_v(s), H_w(s) = sigma sqrt(L / (pi V)) (1 + sqrt(3) (L/V) s) / (1 + (L/V) s)^2
with, at height h (ft), L_w = h, L_u = L_v = h / (0.177 + 0.000823 h)^1.2,
sigma_w = 0.1 W20, sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4, and W20, the wind
speed at 20 ft, 15 / 30 / 45 knots for light / moderate / severe turbulence. A multirotor flies
below the model's 10 ft floor, so h is held at 10 ft. V, the speed at which the frozen
turbulence field passes the vehicle, is the mean wind speed (at least 1 m/s). Each filter is
discretised exactly for its poles and scaled so that its stationary standard deviation is the
specification's sigma.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from quadsim.core import exact
from quadsim.core.kinematics import Vec3
from quadsim.errors import ConfigError

KNOT_MPS = 0.514444
FOOT_M = 0.3048
#: the height the low-altitude Dryden lengths and intensities are taken at (the model's 10 ft floor)
TURBULENCE_HEIGHT_M = 10.0 * FOOT_M
#: the slowest speed the turbulence field is taken to pass the vehicle at, m/s
MIN_TURBULENCE_AIRSPEED_MPS = 1.0
#: the strongest mean wind accepted, m/s
MAX_WIND_MPS = 50.0


class Turbulence(enum.Enum):
    """MIL-F-8785C turbulence intensity, by its wind speed at 20 ft (knots)."""

    LIGHT = "light"
    MODERATE = "moderate"
    SEVERE = "severe"

    @property
    def w20_mps(self) -> float:
        knots = {"light": 15.0, "moderate": 30.0, "severe": 45.0}[self.value]
        return knots * KNOT_MPS


def dryden_sigmas_mps(turbulence: Turbulence, height_m: float = TURBULENCE_HEIGHT_M) -> Vec3:
    """(sigma_u, sigma_v, sigma_w), m/s, of the low-altitude model at `height_m`."""
    h_ft = height_m / FOOT_M
    sigma_w = 0.1 * turbulence.w20_mps
    sigma_uv = sigma_w / (0.177 + 0.000823 * h_ft) ** 0.4
    return (sigma_uv, sigma_uv, sigma_w)


def dryden_lengths_m(height_m: float = TURBULENCE_HEIGHT_M) -> Vec3:
    """(L_u, L_v, L_w), m, of the low-altitude model at `height_m`."""
    h_ft = height_m / FOOT_M
    l_uv = h_ft / (0.177 + 0.000823 * h_ft) ** 1.2
    return (l_uv * FOOT_M, l_uv * FOOT_M, height_m)


@dataclass(frozen=True)
class WindSettings:
    """A run's wind: a mean wind (speed, meteorological FROM direction) and turbulence."""

    speed_mps: float = 0.0
    from_deg: float = 0.0
    turbulence: Turbulence | None = None

    def __post_init__(self) -> None:
        for name in ("speed_mps", "from_deg"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ConfigError(f"wind {name} must be a finite number, got {value!r}")
        if not 0.0 <= self.speed_mps <= MAX_WIND_MPS:
            turned = (
                f" (wind from the opposite side: {-self.speed_mps:g},{(self.from_deg + 180.0) % 360.0:g})"
                if -MAX_WIND_MPS <= self.speed_mps < 0
                else ""
            )
            raise ConfigError(f"wind speed {self.speed_mps:g} m/s is outside [0, {MAX_WIND_MPS:g}] m/s{turned}")
        if self.turbulence is not None and not isinstance(self.turbulence, Turbulence):
            raise ConfigError(f"turbulence must be one of light, moderate, severe, got {self.turbulence!r}")

    @property
    def enabled(self) -> bool:
        """True when there is any wind at all."""
        return self.speed_mps > 0.0 or self.turbulence is not None

    @property
    def mean_mps(self) -> Vec3:
        """The mean wind velocity in `world` (where the air goes: opposite the FROM direction)."""
        rad = math.radians(self.from_deg)
        return (-self.speed_mps * math.sin(rad), -self.speed_mps * math.cos(rad), 0.0)

    def describe(self) -> str:
        """One line for people: 'wind 5 m/s from 90 deg, moderate turbulence', or 'no wind'."""
        if not self.enabled:
            return "no wind"
        bearing = self.from_deg % 360.0 + 0.0  # 400 is from 40 deg, -90 from 270 (and -0.0 is 0)
        parts = [f"wind {self.speed_mps:g} m/s from {bearing:g} deg"] if self.speed_mps > 0.0 else []
        if self.turbulence is not None:
            parts.append(f"{self.turbulence.value} turbulence")
        return ", ".join(parts) if self.speed_mps > 0.0 else "no mean wind, " + parts[0]

    def to_dict(self) -> dict[str, object]:
        return {
            "speed_mps": self.speed_mps,
            "from_deg": self.from_deg,
            "turbulence": None if self.turbulence is None else self.turbulence.value,
        }


def parse_wind(text: str) -> tuple[float, float]:
    """`SPEED,FROM_DEG` (m/s, degrees clockwise from north) -> (speed, from_deg)."""
    try:
        speed, from_deg = (float(part) for part in text.split(","))
    except ValueError:  # not a number, or not two of them
        raise ConfigError(f"--wind must look like SPEED,FROM_DEG (e.g. 3,90), got {text!r}") from None
    if not (math.isfinite(speed) and math.isfinite(from_deg)):
        raise ConfigError(f"--wind must be finite numbers, got {text!r}")
    return speed, from_deg


def wind_from_text(wind: str | None, turbulence: str | None) -> WindSettings:
    """A run's wind as the command line and sweep files give it: `SPEED,FROM_DEG` (None: no
    mean wind) and a turbulence level (None or "none": no turbulence)."""
    speed, from_deg = parse_wind(wind) if wind is not None else (0.0, 0.0)
    return WindSettings(speed, from_deg, None if turbulence in (None, "none") else Turbulence(turbulence))


class _FirstOrder:
    """A Gauss-Markov process: the Dryden longitudinal filter, exact for its pole."""

    def __init__(self, sigma: float, time_constant_s: float, dt_s: float) -> None:
        self._a = math.exp(-dt_s / time_constant_s)
        self._b = sigma * math.sqrt(1.0 - self._a * self._a)
        self.y = 0.0

    def step(self, noise: float) -> float:
        self.y = self._a * self.y + self._b * noise
        return self.y


class _SecondOrder:
    """The Dryden lateral / vertical filter: a double pole at -1/T and a zero at -1/(sqrt(3) T).

    States x1, x2 = x1'; T^2 x1'' + 2 T x1' + x1 = w; output c (x1 + sqrt(3) T x2). The
    transition matrix is exact (the double pole's closed form); the output gain is set so the
    stationary standard deviation is sigma."""

    def __init__(self, sigma: float, time_constant_s: float, dt_s: float) -> None:
        t = time_constant_s
        e = math.exp(-dt_s / t)
        # exp(A dt) = e^(-dt/T) (I + dt (A + I/T)), A = [[0, 1], [-1/T^2, -2/T]]
        phi = np.array([[1.0 + dt_s / t, dt_s], [-dt_s / (t * t), 1.0 - dt_s / t]]) * e
        gamma = np.array([0.0, math.sqrt(dt_s) / (t * t)])
        # the stationary covariance: cov = phi cov phi^T + gamma gamma^T, solved in exact
        # arithmetic (the same bits on every machine: quadsim.core.exact)
        cov = exact.solve((np.eye(4) - np.kron(phi, phi)).tolist(), np.outer(gamma, gamma).ravel().tolist())
        shape = np.array([1.0, math.sqrt(3.0) * t])
        gain = sigma / math.sqrt(exact.quadratic_form(shape.tolist(), [cov[0:2], cov[2:4]]))
        (self._p00, self._p01), (self._p10, self._p11) = phi.tolist()
        self._g1 = float(gamma[1])
        self._c1, self._c2 = gain, gain * float(shape[1])
        self._x1 = self._x2 = 0.0

    def step(self, noise: float) -> float:
        x1, x2 = self._x1, self._x2
        self._x1 = self._p00 * x1 + self._p01 * x2
        self._x2 = self._p10 * x1 + self._p11 * x2 + self._g1 * noise
        return self._c1 * self._x1 + self._c2 * self._x2


#: normal draws taken from the generator at a time (the stream is the same whatever the block)
_BLOCK = 1024


class WindField:
    """The wind at the vehicle, advanced once per physics step, from its own random stream."""

    def __init__(self, settings: WindSettings, dt_s: float, rng: np.random.Generator) -> None:
        self.mean_mps = settings.mean_mps
        self._rng = rng
        rad = math.radians(settings.from_deg)
        # unit vectors of the gust frame in world: along the mean wind, across it (to its left)
        self._along = (-math.sin(rad), -math.cos(rad))
        self._across = (-self._along[1], self._along[0])
        self._filters: tuple[_FirstOrder, _SecondOrder, _SecondOrder] | None = None
        if settings.turbulence is not None:
            airspeed = max(settings.speed_mps, MIN_TURBULENCE_AIRSPEED_MPS)
            su, sv, sw = dryden_sigmas_mps(settings.turbulence)
            lu, lv, lw = dryden_lengths_m()
            self._filters = (
                _FirstOrder(su, lu / airspeed, dt_s),
                _SecondOrder(sv, lv / airspeed, dt_s),
                _SecondOrder(sw, lw / airspeed, dt_s),
            )
        self._noise: list[list[float]] = []
        self._next = 0
        self.wind_mps: Vec3 = self.mean_mps

    def advance(self, position_m: Vec3 = (0.0, 0.0, 0.0)) -> Vec3:
        """The wind for the next physics step, world frame, m/s (the same everywhere: the vehicle's
        `position_m` is for a model of one's own)."""
        if self._filters is None:
            return self.wind_mps
        if self._next >= len(self._noise):
            self._noise = self._rng.standard_normal((_BLOCK, 3)).tolist()
            self._next = 0
        nu, nv, nw = self._noise[self._next]
        self._next += 1
        fu, fv, fw = self._filters
        u, v, w = fu.step(nu), fv.step(nv), fw.step(nw)
        mx, my, mz = self.mean_mps
        (ax, ay), (cx, cy) = self._along, self._across
        self.wind_mps = (mx + u * ax + v * cx, my + u * ay + v * cy, mz + w)
        return self.wind_mps


class WindModel(Protocol):
    """A wind of one's own: the air's velocity at a time and a place.

    `velocity_mps(time_s, position_m)`: the wind (world frame, m/s; REP 103: x east, y north, z
    up) at `time_s` of simulation time since the run's start (or its last reset) and at
    `position_m` (base_link's origin, world frame, m), asked once per physics step for each
    vehicle, before the step. Optional: `reset(rng)`, called as the run starts and at each
    reset with a numpy Generator seeded from the run's seed (a random model re-flies bit for bit
    when it draws from it alone), and `describe()`, JSON-able settings a recording keeps. A
    recording names the model's class (module:Class), and `check` makes it again as
    `Class.from_description(details)` where it has that classmethod, else `Class()`."""

    def velocity_mps(self, time_s: float, position_m: Vec3) -> Vec3: ...


#: the methods a wind model of one's own must have
WIND_MODEL_METHODS = ("velocity_mps",)
#: the strongest wind a model may give, m/s (anything beyond is a bug, said as one)
MAX_MODEL_WIND_MPS = 1000.0


class ModelWind:
    """A WindModel asked once per physics step, as the built-in field is advanced."""

    def __init__(self, model: WindModel, dt_s: float) -> None:
        self.model = model
        self._dt_s = dt_s
        self._step = 0
        self.wind_mps: Vec3 = (0.0, 0.0, 0.0)

    def advance(self, position_m: Vec3) -> Vec3:
        """The model's wind for the next physics step, checked: three finite numbers."""
        given = self.model.velocity_mps(self._step * self._dt_s, position_m)
        self._step += 1
        try:
            wx, wy, wz = (float(v) for v in given)
        except (TypeError, ValueError):
            raise ConfigError(f"the wind model gave {given!r:.80}, not three numbers (x, y, z in m/s)") from None
        if not all(math.isfinite(v) and abs(v) <= MAX_MODEL_WIND_MPS for v in (wx, wy, wz)):
            raise ConfigError(
                f"the wind model gave {given!r:.80}: three finite speeds within {MAX_MODEL_WIND_MPS:g} m/s"
            )
        self.wind_mps = (wx, wy, wz)
        return self.wind_mps
