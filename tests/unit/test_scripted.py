"""The script format, its errors (naming the line), and the built-in scenarios."""

import pytest

from quadsim import ScriptError, Twist, ZMode
from quadsim.drivers.scripted import ScriptedDriver, builtin_scenarios, load_script, parse_script


def test_parse_segments_and_z_mode():
    script = parse_script(
        "# demo\nz_mode height\n2.0 linear.z=0.5  # up\n1.5 linear.x=1 angular.z=-0.5\n1\nsilence 2\n"
    )
    assert script.z_mode is ZMode.HEIGHT
    assert [s.duration_s for s in script.segments] == [2.0, 1.5, 1.0, 2.0]
    assert script.segments[1].twist == Twist(linear_x=1.0, angular_z=-0.5)
    assert script.segments[2].twist == Twist() and script.segments[3].twist is None
    assert script.duration_s == 6.5


@pytest.mark.parametrize(
    "text,line,words",
    [
        ("1.0 linear.x=1\nfast linear.x=2\n", 2, "duration must be a number"),
        ("1.0\n\n2.0 linear.q=1\n", 3, "FIELD=VALUE"),
        ("z_mode sideways\n", 1, "z_mode"),
        ("-1.0\n", 1, "> 0"),
        ("1.0 linear.x=nan\n", 1, "finite"),
        # a later z_mode line applied to the whole script, the commands before it included
        ("2.0 linear.z=1\nz_mode height\n2.0 linear.z=2\n", 2, "one z_mode line before its first command"),
        ("z_mode height\nz_mode velocity\n1.0\n", 2, "a z_mode line came before"),
    ],
)
def test_errors_name_the_line(text, line, words):
    with pytest.raises(ScriptError) as err:
        parse_script(text, "my.qscript")
    assert f"my.qscript, line {line}" in str(err.value) and words in str(err.value)


def test_a_script_longer_than_a_run_may_fly_is_refused(tmp_path, capsys):
    """1e9 s flew (no progress for hours: a crafted or mistyped file); 7 days, as --duration."""
    assert parse_script("604800 linear.z=0\n", "week").duration_s == 604800.0
    with pytest.raises(ScriptError, match=r"huge: its lines last 1e\+09 s, more than a run may fly \(7 days"):
        parse_script("1e9 linear.z=0\n", "huge")
    with pytest.raises(ScriptError, match="more than a run may fly"):
        parse_script("400000\n400000 linear.x=1\n", "two")
    from tests.integration.test_cli_errors import assert_one_line_error, run_cli

    (tmp_path / "huge.qscript").write_text("1e9 linear.z=0\n")
    code, _, err = run_cli(capsys, "run", "--script", str(tmp_path / "huge.qscript"), "--no-record")
    assert_one_line_error(code, err, "huge.qscript: its lines last 1e+09 s")


def test_empty_script_is_refused():
    with pytest.raises(ScriptError, match="no command lines"):
        parse_script("# nothing\n", "x")


def test_builtin_scenarios_exist_and_parse():
    names = builtin_scenarios()
    assert {"hover", "takeoff", "square", "yaw", "figure8"} <= set(names)
    for name in names:
        assert load_script(name).duration_s > 0


def test_unknown_scenario_lists_builtins():
    with pytest.raises(ScriptError) as err:
        load_script("loop-the-loop")
    assert "unknown scenario 'loop-the-loop'" in str(err.value) and "figure8" in str(err.value)


def test_driver_follows_the_timeline():
    driver = ScriptedDriver(parse_script("1.0 linear.x=1\n0.5 linear.y=2\n"))
    assert driver.poll(0, 0.0) == Twist(linear_x=1.0)
    assert driver.poll(0, 0.95) == Twist(linear_x=1.0)
    assert driver.poll(0, 1.0) == Twist(linear_y=2.0)
    assert not driver.finished
    assert driver.poll(0, 1.5) is None and driver.finished


@pytest.mark.parametrize(
    ("name", "says"),
    [
        ("", "no script named"),
        ("  ", "no script named"),
        ("{tmp}", "not a script file (a directory or a device)"),
        ("/dev/zero", "not a script file (a directory or a device)"),
        ("{tmp}/huge.qscript", "is larger than 4 MB"),
        ("{tmp}/latin1.qscript", "is not a UTF-8 text file"),
        ("{tmp}/missing.qscript", "script file not found"),
    ],
)
def test_a_script_path_that_is_not_a_small_text_file_is_refused_in_one_line(tmp_path, name, says):
    with open(tmp_path / "huge.qscript", "wb") as fh:  # sparse: 5 GB it never reads
        fh.truncate(5 * 1024**3)
    (tmp_path / "latin1.qscript").write_bytes("1.0 linear.x=1 # caf\u00e9\n".encode("latin-1"))
    with pytest.raises(ScriptError) as refused:
        load_script(name.format(tmp=tmp_path))
    assert says in str(refused.value) and "\n" not in str(refused.value)
