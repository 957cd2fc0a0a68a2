"""Wind: a constant wind (meteorological FROM direction), Dryden turbulence of MIL-F-8785C
intensity, one seed per run; what it does to the vehicle, what is recorded, and re-flying it."""

import math

import numpy as np
import pytest

from quadsim import SimConfig, Simulator, StateLog, Twist
from quadsim.apps.flight_quality import PHYSICS_TARGETS, wind_hover_metrics
from quadsim.errors import ConfigError
from quadsim.physics.wind import (
    Turbulence,
    WindField,
    WindSettings,
    dryden_lengths_m,
    dryden_sigmas_mps,
    parse_wind,
)


@pytest.mark.parametrize(
    "from_deg,expected",
    [(90.0, (-3.0, 0.0)), (0.0, (0.0, -3.0)), (180.0, (0.0, 3.0)), (270.0, (3.0, 0.0))],
)
def test_wind_blows_from_the_meteorological_direction(from_deg, expected):
    # from the east (90) the air moves west (-x); from the north (0, +y) it moves south (-y)
    mean = WindSettings(3.0, from_deg).mean_mps
    assert mean[0] == pytest.approx(expected[0], abs=1e-12) and mean[1] == pytest.approx(expected[1], abs=1e-12)
    assert parse_wind("3,90") == (3.0, 90.0)
    for bad in ("3", "3,90,1", "x,90", "3,nan"):
        with pytest.raises(ConfigError, match="--wind"):
            parse_wind(bad)
    with pytest.raises(ConfigError, match="outside"):
        WindSettings(-1.0, 0.0)


def test_the_wind_is_described_from_a_bearing_between_0_and_360():
    """--wind 3,400 blows from 40 deg and was shown as 'from 400 deg'."""
    for given, shown in ((400.0, "40"), (-90.0, "270"), (360.0, "0"), (-0.0, "0"), (90.0, "90")):
        assert WindSettings(3.0, given).describe() == f"wind 3 m/s from {shown} deg"
    assert WindSettings(3.0, 400.0).mean_mps == pytest.approx(WindSettings(3.0, 40.0).mean_mps, abs=1e-12)


def test_dryden_intensities_and_lengths_are_the_military_specifications():
    # MIL-F-8785C low altitude at 10 ft: sigma_w = 0.1 W20; W20 = 15/30/45 knots
    for turbulence, knots in ((Turbulence.LIGHT, 15), (Turbulence.MODERATE, 30), (Turbulence.SEVERE, 45)):
        su, sv, sw = dryden_sigmas_mps(turbulence)
        assert sw == pytest.approx(0.1 * knots * 0.514444)
        assert su == sv == pytest.approx(sw / (0.177 + 0.000823 * 10.0) ** 0.4)
    lu, lv, lw = dryden_lengths_m()
    assert lw == pytest.approx(3.048) and lu == lv == pytest.approx(10.0 / (0.177 + 0.00823) ** 1.2 * 0.3048)


def _samples(settings: WindSettings, seed: int, steps: int, dt_s: float) -> np.ndarray:
    field = WindField(settings, dt_s, np.random.Generator(np.random.PCG64(seed)))
    return np.array([field.advance() for _ in range(steps)])


def test_turbulence_has_the_specified_spread_about_the_mean_wind():
    settings = WindSettings(5.0, 90.0, Turbulence.MODERATE)
    wind = _samples(settings, 1, 90_000, 1.0 / 30.0)  # 50 minutes: ~600 gust lengths across
    su, sv, sw = dryden_sigmas_mps(Turbulence.MODERATE)
    # gust frame: along the mean wind (-x from the east), across it (y), vertical
    assert wind.mean(axis=0) == pytest.approx((-5.0, 0.0, 0.0), abs=0.6)
    assert wind.std(axis=0) == pytest.approx((su, sv, sw), rel=0.15)
    # the along-wind gust is a Gauss-Markov process of time constant L_u / V: correlation 1/e there
    lag = round(dryden_lengths_m()[0] / 5.0 * 30.0)
    u = wind[:, 0] - wind[:, 0].mean()
    assert float(np.dot(u[:-lag], u[lag:]) / np.dot(u, u)) == pytest.approx(math.exp(-1.0), abs=0.1)


def test_the_seed_decides_the_gusts():
    settings = WindSettings(2.0, 30.0, Turbulence.LIGHT)
    a, b, c = (_samples(settings, seed, 500, 1 / 240) for seed in (3, 3, 4))
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert np.array_equal(
        _samples(WindSettings(2.0, 30.0), 5, 10, 1 / 240), np.tile(WindSettings(2.0, 30.0).mean_mps, (10, 1))
    )


def test_the_cascade_holds_a_hover_within_half_a_metre_in_moderate_turbulence_and_5mps_wind():
    (low, high) = next((lo, hi) for s, m, lo, hi in PHYSICS_TARGETS if s == "hover_wind")
    drift = wind_hover_metrics()["drift_m"]
    assert low <= drift < high == 0.5


def test_wind_pushes_a_hovering_vehicle_the_way_it_blows_until_the_controller_leans_into_it():
    with Simulator(SimConfig(wind=WindSettings(6.0, 0.0), sensor_noise=False)) as sim:  # from the north
        log = StateLog()
        sim.add_sink(log)
        sim.send(Twist(linear_z=1.0))
        sim.run_for(2.0)
        sim.send(Twist())
        state = sim.run_for(10.0)
    assert min(s.position_m[1] for s in log.states) < -0.02  # pushed south before the integrator caught up
    assert abs(state.position_m[1]) < 0.05 and math.hypot(*state.linear_velocity_mps) < 0.01
    roll, pitch = state.roll_pitch_rad()
    assert roll < -0.05 and abs(pitch) < 0.02  # leaning north (+y) into the wind: a negative roll about x
    assert all(s.wind_mps == pytest.approx((0.0, -6.0, 0.0)) for s in log.states)
