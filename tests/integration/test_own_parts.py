"""Your own parts: a controller object (the Controller protocol) and a wind model (the WindModel
protocol) fly in a Simulator, a Fleet and the envs beside the built-in ones; a recording names
their classes, and `check` makes them again and re-flies the run, or says in one line why it
cannot."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from quadsim import (
    ConfigError,
    Fleet,
    FleetVehicle,
    QuadsimError,
    SimConfig,
    Simulator,
    StartPose,
    StateLog,
    Twist,
    ZMode,
    record,
)
from quadsim.apps.regression import CheckTask, check_one
from quadsim.assets.examples.own_controller import SmallAngleController
from quadsim.core.parts import part_class
from quadsim.drivers.scripted import ScriptedDriver, load_script
from quadsim.recording.flight import load_flights
from quadsim.vehicle.params import load_vehicle
from tests.helpers import ROOT
from tests.helpers.own_parts import BrokenWind, GustyWind, ShearWind

OWN_CONTROLLER = "quadsim.assets.examples.own_controller:SmallAngleController"


def _fly_square(out: Path) -> StateLog:
    script = load_script("square")
    log = StateLog()
    controller = SmallAngleController(load_vehicle())
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT), ScriptedDriver(script), controller=controller) as sim:
        sim.add_sink(log)
        with record(sim, out):
            sim.run_for(script.duration_s)
    return log


def test_your_own_controller_flies_the_square_and_check_flies_it_again(tmp_path):
    path = tmp_path / "own.mcap"
    log = _fly_square(path)
    xs, ys = [s.position_m[0] for s in log.states], [s.position_m[1] for s in log.states]
    assert 2.6 < max(xs) < 3.4 and 2.6 < max(ys) < 3.4  # a 3 m square, forward then left
    end = log.states[-1].position_m
    assert math.hypot(end[0], end[1]) < 0.3 and abs(end[2] - 2.0) < 0.2  # back at the start, 2 m up
    (flight,) = load_flights(path).values()
    assert flight.description is not None
    assert flight.description.controller.kind is None and flight.description.controller.import_path == OWN_CONTROLLER
    outcome = check_one(CheckTask(path, 1e-3, 1e-3))
    assert outcome.status == "ok" and "flies again identically" in outcome.lines[0], outcome.lines


def test_a_controller_that_does_not_import_is_said_in_one_line(tmp_path):
    """A recording whose controller's module is not on the Python path: `check` says so, exit 2."""
    module = tmp_path / "elsewhere"
    module.mkdir()
    source = (ROOT / "quadsim" / "assets" / "examples" / "own_controller.py").read_text()
    (module / "gone_controller.py").write_text(source)
    sys.path.insert(0, str(module))
    try:
        from gone_controller import SmallAngleController as Gone  # type: ignore[import-not-found]

        with Simulator(SimConfig(), controller=Gone(load_vehicle())) as sim, record(sim, tmp_path / "gone.mcap"):
            sim.send(Twist(linear_z=1.0))
            sim.run_for(1.0)
    finally:
        sys.path.remove(str(module))
        sys.modules.pop("gone_controller", None)
    done = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "check", str(tmp_path / "gone.mcap")],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
    )
    assert done.returncode == 2, done.stdout + done.stderr
    assert "the controller gone_controller:SmallAngleController does not import here" in done.stdout
    assert "Traceback" not in done.stdout + done.stderr


@pytest.mark.parametrize(
    "path, said",
    [
        ("__main__:Mine", "defined in the program that flew it"),
        ("os:system", "is not a controller"),
        ("subprocess:Popen", "is not a controller"),
        ("../../etc/passwd:X", "is not an import path"),
        ("a" * 400 + ":B", "is not an import path"),
        ("no_such_module_here:Thing", "does not import here"),
    ],
)
def test_a_named_part_is_imported_only_when_it_is_one(path, said):
    """A recording names a class, never a file, and nothing is called before the class is found to
    have the part's methods."""
    with pytest.raises(QuadsimError, match=said):
        part_class(path, "controller", ("reset", "update", "describe"))


def test_your_own_wind_blows_records_and_flies_again_bit_for_bit(tmp_path):
    path = tmp_path / "gusty.mcap"
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT, seed=5), wind=GustyWind(1.5)) as sim, record(sim, path):
        log = StateLog()
        sim.add_sink(log)
        sim.send(Twist())  # hold 2 m
        sim.run_for(6.0)
    winds = {s.wind_mps for s in log.states if s.wind_mps is not None}
    assert all(w[0] == 0.0 and 0.5 <= w[1] <= 3.5 for w in winds) and len(winds) > 3  # gusts, one a second
    (flight,) = load_flights(path).values()
    assert flight.description is not None and flight.description.wind_model is not None
    assert flight.description.wind_model.import_path == "tests.helpers.own_parts:GustyWind"
    assert flight.description.wind_model.details == {"gust_mps": 1.5}
    outcome = check_one(CheckTask(path, 1e-3, 1e-3))
    assert outcome.status == "ok" and "flies again identically" in outcome.lines[0], outcome.lines
    info = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "info", str(path)], capture_output=True, text=True, timeout=120
    )
    assert "wind of its own (tests.helpers.own_parts:GustyWind)" in info.stdout


def test_a_shear_wind_pushes_harder_higher():
    """The model is asked at the vehicle's place: the same hover drifts more at 4 m than at 2 m."""
    drift = {}
    for height in (0.0, 2.0):  # height z-mode: 2 m and 4 m
        with Simulator(SimConfig(z_mode=ZMode.HEIGHT), wind=ShearWind()) as sim:
            sim.send(Twist(linear_z=height))
            sim.run_for(4.0)
            drift[height] = sim.state.position_m[0]
    assert drift[2.0] > drift[0.0] > 0.0


def test_a_wind_model_that_breaks_is_said_in_one_line():
    with Simulator(SimConfig(), wind=BrokenWind()) as sim:
        sim.send(Twist(linear_z=1.0))
        with pytest.raises(ConfigError, match=r"the wind model gave \(nan, 0.0, 0.0\)"):
            sim.run_for(1.0)


def test_a_wind_model_and_the_configs_wind_are_refused_together():
    from quadsim import WindSettings

    with pytest.raises(ConfigError, match="a wind model and the config's wind"):
        Simulator(SimConfig(wind=WindSettings(3.0, 90.0)), wind=ShearWind())


def test_a_fleet_flies_its_own_controllers_in_its_own_wind_and_check_flies_it_again(tmp_path):
    vehicle = load_vehicle()
    vehicles = [
        FleetVehicle("alpha", controller=SmallAngleController(vehicle), driver=ScriptedDriver(load_script("square"))),
        FleetVehicle("bravo", start=StartPose(0.0, 4.0)),  # the cascade
        FleetVehicle(
            "charlie", start=StartPose(-4.0, 0.0), controller=SmallAngleController(vehicle, velocity_p_per_s=1.0)
        ),
    ]
    path = tmp_path / "fleet.mcap"
    with Fleet(vehicles, SimConfig(z_mode=ZMode.HEIGHT, seed=2), wind=GustyWind(1.0)) as fleet, record(fleet, path):
        fleet["bravo"].send(Twist())
        fleet["charlie"].send(Twist(linear_z=1.0))
        fleet.run_for(8.0)
        assert fleet["charlie"].state.position_m[2] > 2.5 and fleet["bravo"].state.position_m[2] > 1.5
    flights = load_flights(path)
    kinds = {name: f.description.controller for name, f in flights.items() if f.description is not None}
    assert kinds["alpha"].import_path == OWN_CONTROLLER and kinds["bravo"].name == "cascade"
    assert kinds["charlie"].details["gains"]["velocity_p_per_s"] == 1.0
    outcome = check_one(CheckTask(path, 1e-3, 1e-3))
    assert outcome.status == "ok" and "(a fleet of 3)" in outcome.lines[0], outcome.lines


def test_the_envs_take_your_own_controller_and_wind():
    pytest.importorskip("gymnasium")
    from quadsim.envs.quad import HoverEnv

    controller = SmallAngleController(load_vehicle())
    env = HoverEnv(wind=ShearWind(), controller=controller)
    try:
        env.reset(seed=1)
        for _ in range(30):
            env.step(env.action_space.sample() * 0.0)
        assert env.unwrapped.sim.controller is controller
        assert env.unwrapped.sim.state.wind_mps is not None
    finally:
        env.close()
