"""The second airframe preset, a Crazyflie 2.x sized quadrotor (27 g): data files only, flying
the scenarios with gains from its own file. And gains as data in general."""

import shutil
from pathlib import Path

import pytest

from quadsim import ControllerKind, SimConfig, Simulator
from quadsim.apps.flight_quality import SCENARIO_METRICS, TARGETS, fly
from quadsim.control import make_controller
from quadsim.control.gains import gains_path
from quadsim.errors import ConfigError
from quadsim.vehicle.params import DEFAULT_URDF, SHIPPED_VEHICLES, load_vehicle

CF = SHIPPED_VEHICLES["crazyflie"]


def test_its_mass_and_inertia_are_foersters_identification():
    v = load_vehicle(CF)
    assert v.mass_kg == pytest.approx(0.027)
    (ixx, _, _), (_, iyy, _), (_, _, izz) = v.inertia_kgm2
    assert (ixx, iyy, izz) == pytest.approx((1.657e-5, 1.666e-5, 2.926e-5), rel=0.01)
    assert v.rotor_count == 4 and max(abs(r.position_m[0]) for r in v.rotors) < 0.034  # 92 mm diagonal


@pytest.fixture(scope="module")
def cf_metrics():
    config = SimConfig(urdf=CF)
    return {
        name: SCENARIO_METRICS[name](fly(name, ControllerKind.CASCADE, config)) for name in {s for s, _, _ in TARGETS}
    }


@pytest.mark.parametrize("scenario,metric,bound", TARGETS, ids=[f"{s}-{m}" for s, m, _ in TARGETS])
def test_it_flies_the_scenarios_to_the_cascades_targets(cf_metrics, scenario, metric, bound):
    assert cf_metrics[scenario][metric] < bound, cf_metrics[scenario]


def test_its_gains_come_from_its_own_file_and_are_recorded():
    with Simulator(SimConfig(urdf=CF)) as cf, Simulator(SimConfig()) as quad:
        cf_gains, quad_gains = cf.description().controller.gains, quad.description().controller.gains
    assert gains_path(load_vehicle(CF)) == CF.with_suffix(".gains.toml")
    assert cf_gains["attitude_p_per_s"] == 12.0 and quad_gains["attitude_p_per_s"] == 9.0
    assert cf_gains["max_tilt_rad"] < quad_gains["max_tilt_rad"]


def _copy(tmp_path: Path) -> Path:
    urdf = tmp_path / "mine.urdf"
    shutil.copy(DEFAULT_URDF, urdf)
    shutil.copy(DEFAULT_URDF.with_suffix(".params.toml"), tmp_path / "mine.params.toml")
    return urdf


def test_a_vehicle_without_a_gains_file_flies_with_the_default_airframes(tmp_path):
    vehicle = load_vehicle(_copy(tmp_path))
    assert gains_path(vehicle) == DEFAULT_URDF.with_suffix(".gains.toml")
    assert make_controller(ControllerKind.CASCADE, vehicle).describe()["gains"]["position_p_per_s"] == 2.0


@pytest.mark.parametrize(
    "edit,named",
    [
        (
            lambda t: t.replace("position_p_per_s = 2.0", "position_p_per_s = 2.0\nspeed_boost = 3.0"),
            "unknown gains speed_boost",
        ),
        (lambda t: t.replace("altitude_p_per_s = 2.0", ""), "missing gains altitude_p_per_s"),
        (
            lambda t: t.replace("heading_p_per_s = 2.5", 'heading_p_per_s = "fast"'),
            "heading_p_per_s = 'fast': expected a finite number",
        ),
        (
            lambda t: t.replace("heading_p_per_s = 2.5", "heading_p_per_s = -2.5"),
            "heading_p_per_s = -2.5: expected a number >= 0",
        ),
        (lambda t: t.replace("[cascade]", "[cascade_gains]"), "missing the [cascade] table"),
    ],
)
def test_a_bad_gains_file_is_refused_naming_the_file_and_gain(tmp_path, edit, named):
    urdf = _copy(tmp_path)
    urdf.with_suffix(".gains.toml").write_text(edit(DEFAULT_URDF.with_suffix(".gains.toml").read_text()))
    with pytest.raises(ConfigError, match=r"mine\.gains\.toml") as err:
        make_controller(ControllerKind.CASCADE, load_vehicle(urdf))
    assert named in str(err.value)
