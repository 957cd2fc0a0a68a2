"""A key a world, vehicle-parameter or gains file does not know is refused, never ignored.

A typo (`[[landmarks]]`, `fricton`, `colour`) once left a world silently empty or plain, and a
fleet file given as a world flew an empty one. Each file kind now refuses it in one line naming
the file, the table and the key, with the near miss suggested; every shipped file still loads.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from quadsim.assets import asset_path
from quadsim.control import ControllerKind, gains_type
from quadsim.control.gains import gains_path, load_gains
from quadsim.errors import ConfigError
from quadsim.physics.world_spec import DEFAULT_WORLD, load_world
from quadsim.recording.reader import RecordingReader
from quadsim.sim.fleet_file import load_fleet_file
from quadsim.vehicle.params import DEFAULT_URDF, SHIPPED_VEHICLES, load_vehicle
from tests.helpers.recording import SHIPPED_RECORDINGS

LANDMARK = 'name = "tower"\nshape = "box"\nposition_m = [6.0, 0.0, 1.5]\nsize_m = [0.8, 0.8, 3.0]\n'
FLEET = asset_path("examples", "fleet.toml")


def _one_line(exc: pytest.ExceptionInfo[ConfigError], *parts: str) -> str:
    said = str(exc.value)
    assert "\n" not in said, said
    for part in parts:
        assert part in said, f"{part!r} not in {said!r}"
    return said


# --- world files ----------------------------------------------------------------------------

WORLD_CASES = [
    (
        "a_misspelt_table_of_landmarks",
        "[floor]\nsize_m = 40.0\n[[landmarks]]\n" + LANDMARK + "color_rgba = [1.0, 0.0, 0.0, 1.0]\n",
        "w.toml: unknown table [[landmarks]] (did you mean [[landmark]]?)",
    ),
    (
        "a_misspelt_floor_key",
        "[floor]\nfricton = 0.1\n",
        "w.toml: [floor]: unknown key 'fricton' (did you mean 'friction'?)",
    ),
    (
        "a_misspelt_landmark_key",
        "[[landmark]]\n" + LANDMARK + "colour = [1.0, 0.0, 0.0, 1.0]\n",
        "w.toml: landmark 1 (tower): unknown key 'colour' (did you mean 'color_rgba'?)",
    ),
    (
        "a_key_nothing_is_near",
        "[floor]\nsize_m = 40.0\nbogus_key = 3\n",
        "w.toml: [floor]: unknown key 'bogus_key' (known: size_m, texture, texture_tile_m, friction)",
    ),
    (
        "a_top_level_key",
        "bogus_key = 3\n[floor]\nsize_m = 40.0\n",
        "w.toml: unknown key 'bogus_key' (a world file has [floor] and [[landmark]] tables)",
    ),
]


@pytest.mark.parametrize(("text", "says"), [c[1:] for c in WORLD_CASES], ids=[c[0] for c in WORLD_CASES])
def test_a_world_file_with_an_unknown_key_is_refused_naming_file_table_and_key(tmp_path, text, says):
    path = tmp_path / "w.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_world(path)
    assert _one_line(err) == f"{tmp_path}/{says}"


def test_the_unknown_key_is_said_before_the_value_it_leaves_missing(tmp_path):
    """`colour` was reported as "color_rgba must be a list of 4 numbers, got None"."""
    path = tmp_path / "w.toml"
    path.write_text("[[landmark]]\n" + LANDMARK + "colour = [1.0, 0.0, 0.0, 1.0]\n")
    with pytest.raises(ConfigError) as err:
        load_world(path)
    assert "got None" not in _one_line(err, "'colour'")


def test_a_fleet_file_given_as_a_world_is_refused_and_named_as_one(tmp_path):
    path = tmp_path / "fleet.toml"
    shutil.copy(FLEET, path)
    with pytest.raises(ConfigError) as err:
        load_world(path)
    _one_line(err, f"{path}: unknown table [[vehicle]]", "a fleet file?", f"--fleet {path}")


def test_the_shipped_world_and_the_worlds_recordings_hold_still_load(tmp_path):
    assert len(load_world(DEFAULT_WORLD).landmarks) == 5
    worlds = 0
    for recording in SHIPPED_RECORDINGS:  # by name: not what a user adds to the folder
        for name, data in RecordingReader(recording).attachments().items():
            if name.endswith(".toml") and not name.endswith((".params.toml", ".gains.toml")):
                path = tmp_path / recording.stem / name
                path.parent.mkdir(exist_ok=True)
                path.write_bytes(data)
                assert load_world(path, texture_required=False).landmarks, recording.name
                worlds += 1
    assert worlds >= 5


# --- vehicle parameter files ----------------------------------------------------------------


def _vehicle_copy(tmp_path: Path, edit=lambda t: t) -> Path:
    urdf = tmp_path / "mine.urdf"
    shutil.copy(DEFAULT_URDF, urdf)
    text = DEFAULT_URDF.with_suffix(".params.toml").read_text()
    urdf.with_suffix(".params.toml").write_text(edit(text))
    return urdf


PARAMS_CASES = [
    (
        "a_key_in_a_table",
        lambda t: t.replace("[limits]\n", "[limits]\nbogus_key = 3\n"),
        "mine.params.toml: [limits]: unknown key 'bogus_key' (known: max_horizontal_speed_mps, ",
    ),
    (
        "a_top_level_key",
        lambda t: "bogus_key = 3\n" + t,
        "mine.params.toml: unknown key 'bogus_key' (a vehicle parameter file has the tables [rotors], [aero], "
        "[imu], [limits], [contact], [range], [lidar])",
    ),
    (
        "a_misspelt_key",
        lambda t: t.replace("[aero]\n", "[aero]\nrotor_radius = 0.065\n"),
        "mine.params.toml: [aero]: unknown key 'rotor_radius' (did you mean 'rotor_radius_m'?)",
    ),
    (
        "a_misspelt_table",
        lambda t: t + "\n[limit]\nmax_altitude_m = 20.0\n",
        "mine.params.toml: unknown table [limit] (did you mean [limits]?)",
    ),
]


@pytest.mark.parametrize(("edit", "says"), [c[1:] for c in PARAMS_CASES], ids=[c[0] for c in PARAMS_CASES])
def test_a_parameter_file_with_an_unknown_key_is_refused_naming_file_table_and_key(tmp_path, edit, says):
    urdf = _vehicle_copy(tmp_path, edit)
    with pytest.raises(ConfigError) as err:
        load_vehicle(urdf)
    assert _one_line(err).startswith(f"{tmp_path}/{says}")


# --- gains files ----------------------------------------------------------------------------

GAINS_CASES = [
    (
        "a_misspelt_gain_of_the_controller_flown",
        "cascade",
        lambda t: t.replace("position_p_per_s = 2.0", "position_p_per_s = 2.0\nposition_p_per_sec = 2.0"),
        "mine.gains.toml: [cascade]: unknown gains position_p_per_sec (did you mean 'position_p_per_s'?)",
    ),
    (
        "a_gain_in_the_other_controllers_table",
        "cascade",
        lambda t: t.replace("yaw_p = 1.0", "yaw_p = 1.0\nbogus_key = 3"),
        "mine.gains.toml: [seed]: unknown gains bogus_key",
    ),
    (
        "a_misspelt_table",
        "seed",
        lambda t: t + "\n[cascde]\nposition_p_per_s = 2.0\n",
        "mine.gains.toml: unknown table [cascde] (did you mean [cascade]?)",
    ),
    (
        "a_top_level_key",
        "cascade",
        lambda t: "bogus_key = 3\n" + t,
        "mine.gains.toml: unknown key 'bogus_key' (a gains file has one table per controller: [cascade], [seed])",
    ),
]


@pytest.mark.parametrize(("section", "edit", "says"), [c[1:] for c in GAINS_CASES], ids=[c[0] for c in GAINS_CASES])
def test_a_gains_file_with_an_unknown_key_is_refused_naming_file_table_and_key(tmp_path, section, edit, says):
    urdf = _vehicle_copy(tmp_path)
    urdf.with_suffix(".gains.toml").write_text(edit(DEFAULT_URDF.with_suffix(".gains.toml").read_text()))
    vehicle = load_vehicle(urdf)
    kind = ControllerKind(section)
    with pytest.raises(ConfigError) as err:
        load_gains(vehicle, kind.value, gains_type(kind))
    assert _one_line(err) == f"{tmp_path}/{says}"


@pytest.mark.parametrize("airframe", sorted(SHIPPED_VEHICLES))
def test_every_shipped_parameter_and_gains_file_loads(airframe):
    vehicle = load_vehicle(SHIPPED_VEHICLES[airframe])
    assert gains_path(vehicle) == SHIPPED_VEHICLES[airframe].with_suffix(".gains.toml")
    for kind in ControllerKind:
        assert load_gains(vehicle, kind.value, gains_type(kind)) is not None


def test_the_shipped_fleet_example_still_loads_and_refuses_an_unknown_key_as_before(tmp_path):
    assert len(load_fleet_file(FLEET).vehicles) >= 2
    path = tmp_path / "fleet.toml"
    path.write_text(FLEET.read_text().replace("[[vehicle]]\n", "[[vehicle]]\ncolour = 1\n", 1))
    with pytest.raises(ConfigError) as err:
        load_fleet_file(path)
    _one_line(err, f"{path}: vehicle ", ": unknown key 'colour' (known: name, airframe, ")


# --- through the command line ---------------------------------------------------------------
