"""The vehicle is read from the URDF's inertial blocks and the parameter file, and validated."""

import math
import shutil
from pathlib import Path

import pytest

from quadsim.errors import ConfigError
from quadsim.vehicle.params import DEFAULT_URDF, Spin, load_vehicle


def test_mass_and_inertia_come_from_the_urdf(vehicle):
    # base 0.9 + four rotors 0.025 + two cameras 0.005, as written in the URDF
    assert vehicle.mass_kg == pytest.approx(1.01)
    ixx, iyy, izz = (vehicle.inertia_kgm2[i][i] for i in range(3))
    # base inertia plus the rotors' parallel-axis share: 4 * 0.025 * 0.12^2 about x and y
    assert ixx == pytest.approx(0.0072 + 4e-5 + 4 * 0.025 * 0.12**2, rel=0.02)
    assert izz == pytest.approx(0.0130 + 8e-5 + 4 * 0.025 * 2 * 0.12**2, rel=0.02)
    assert abs(vehicle.com_m[0]) < 0.002 and abs(vehicle.com_m[1]) < 1e-9


def test_rotors_come_from_the_rotor_links(vehicle):
    names = [r.link_name for r in vehicle.rotors]
    assert names == ["rotor_1", "rotor_2", "rotor_3", "rotor_4"]
    signs = [(math.copysign(1, r.position_m[0]), math.copysign(1, r.position_m[1])) for r in vehicle.rotors]
    assert signs == [(1, 1), (-1, 1), (-1, -1), (1, -1)]  # front-left, rear-left, rear-right, front-right
    assert [r.spin for r in vehicle.rotors] == [Spin.CCW, Spin.CW, Spin.CCW, Spin.CW]
    assert vehicle.camera_links == ("floor_camera_link", "front_camera_link")


def test_parameters_are_frozen(vehicle):
    from dataclasses import FrozenInstanceError

    with pytest.raises(FrozenInstanceError):
        vehicle.mass_kg = 2.0  # type: ignore[misc]


def _copy_vehicle(tmp_path: Path) -> tuple[Path, Path]:
    urdf = tmp_path / "v.urdf"
    shutil.copy(DEFAULT_URDF, urdf)
    params = tmp_path / "v.params.toml"
    shutil.copy(DEFAULT_URDF.with_suffix(".params.toml"), params)
    return urdf, params


def test_missing_field_names_file_and_field(tmp_path):
    urdf, params = _copy_vehicle(tmp_path)
    params.write_text(params.read_text().replace("motor_time_constant_s = 0.02", ""))
    with pytest.raises(ConfigError) as err:
        load_vehicle(urdf)
    assert "v.params.toml" in str(err.value) and "motor_time_constant_s" in str(err.value)


def test_absurd_value_names_file_and_field(tmp_path):
    urdf, params = _copy_vehicle(tmp_path)
    params.write_text(params.read_text().replace("max_thrust_n = 6.0", "max_thrust_n = -3.0"))
    with pytest.raises(ConfigError) as err:
        load_vehicle(urdf)
    assert "max_thrust_n" in str(err.value) and "v.params.toml" in str(err.value)


def test_too_weak_rotors_are_refused(tmp_path):
    urdf, params = _copy_vehicle(tmp_path)
    params.write_text(params.read_text().replace("max_thrust_n = 6.0", "max_thrust_n = 2.0"))
    with pytest.raises(ConfigError, match="too little to fly"):
        load_vehicle(urdf)


def test_bad_urdf_mass_names_link(tmp_path):
    urdf, _ = _copy_vehicle(tmp_path)
    urdf.write_text(urdf.read_text().replace('<mass value="0.9"/>', '<mass value="zero"/>'))
    with pytest.raises(ConfigError) as err:
        load_vehicle(urdf)
    assert "base_link" in str(err.value) and "mass" in str(err.value)


def test_missing_files_are_named(tmp_path):
    with pytest.raises(ConfigError, match="URDF not found"):
        load_vehicle(tmp_path / "nope.urdf")
    urdf = tmp_path / "lonely.urdf"
    shutil.copy(DEFAULT_URDF, urdf)
    with pytest.raises(ConfigError, match=r"lonely\.params\.toml"):
        load_vehicle(urdf)


def test_rotor_links_must_be_numbered_from_one_without_gaps(tmp_path):
    urdf, _ = _copy_vehicle(tmp_path)
    urdf.write_text(urdf.read_text().replace('"rotor_3"', '"rotor_7"'))
    with pytest.raises(ConfigError, match=r"rotor_1..rotor_N with N >= 4, found \['rotor_1', 'rotor_2', 'rotor_4'"):
        load_vehicle(urdf)


def test_fewer_than_four_rotors_are_refused(tmp_path):
    urdf, params = _copy_vehicle(tmp_path)
    text = urdf.read_text()
    start = text.index('<link name="rotor_4">')
    end = text.index("</joint>", start) + len("</joint>")
    urdf.write_text(text[:start] + text[end:])
    params.write_text(params.read_text().replace(', rotor_4 = "cw"', ""))
    with pytest.raises(ConfigError, match="N >= 4"):
        load_vehicle(urdf)


def test_spins_must_balance(tmp_path):
    urdf, params = _copy_vehicle(tmp_path)
    params.write_text(params.read_text().replace('rotor_4 = "cw"', 'rotor_4 = "ccw"'))
    with pytest.raises(ConfigError, match="as many ccw as cw rotors; 3 of the 4"):
        load_vehicle(urdf)


def test_spin_of_a_rotor_the_urdf_lacks_is_refused(tmp_path):
    urdf, params = _copy_vehicle(tmp_path)
    params.write_text(params.read_text().replace('rotor_4 = "cw"', 'rotor_4 = "cw", rotor_5 = "ccw"'))
    with pytest.raises(ConfigError, match=r"spin names \['rotor_5'\]"):
        load_vehicle(urdf)


def test_a_rotors_entry_that_is_not_a_table_is_refused(tmp_path):
    urdf, params = _copy_vehicle(tmp_path)
    text = params.read_text()
    rotors = text.index("[rotors]")
    end = text.index("\n[", rotors + 1)  # the table, up to the next one
    params.write_text("rotors = 5\n" + text[:rotors] + text[end + 1 :])
    with pytest.raises(ConfigError, match=r"\[rotors\] must be a table, got 5"):
        load_vehicle(urdf)


def test_shipped_vehicles_load():
    from quadsim.vehicle.params import SHIPPED_VEHICLES

    counts = {name: load_vehicle(path).rotor_count for name, path in SHIPPED_VEHICLES.items()}
    assert counts == {"quad": 4, "hexa": 6, "crazyflie": 4}
