"""The CLI as a user meets it: a summary after a run, one-line errors with exit code 2."""

import subprocess
from pathlib import Path

import pytest

from tests.helpers import ROOT
from tests.helpers.cli import bare_env, run_main
from tests.helpers.fleets import RUNS, WINDOW_FLEET, run_args

QUIET = ("--no-record", "--cameras", "none")  # flight-only runs: nothing written, nothing rendered


def cli(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    return run_main(*args, cwd=cwd, env=bare_env(SDL_VIDEODRIVER="dummy"))


#: what `run` says first, for each shape of run (tests.helpers.fleets.RUNS)
FLYING = {
    "alone": "flying 'square' for 27.0 s: controller cascade, ",
    "fleet of 3": "flying a fleet of 3 for 27.0 s: alpha (quad, script square), bravo (hexa, script yaw), "
    "charlie (crazyflie, idle); ",
}


@pytest.mark.parametrize("shape", list(RUNS))
def test_run_prints_summary(shape, tmp_path):
    """What flies, then where each vehicle ended: one vehicle's whole, a fleet's a line each."""
    out = cli(*run_args(shape, tmp_path), "--no-record")
    assert out.returncode == 0, out.stderr
    text = out.stdout
    assert text.startswith(FLYING[shape]) and "real-time factor" in text
    names = [flier.name for flier in RUNS[shape]]
    if names == [""]:
        assert "distance flown" in text
        final = next(line for line in text.splitlines() if line.startswith("final pose"))
    else:
        finals = [line for line in text.splitlines() if " final x=" in line]
        assert [line.split()[0] for line in finals] == names and all("; flown " in line for line in finals)
        final = finals[0]
    x = float(final.split("x=")[1].split()[0])
    z = float(final.split("z=")[1].split()[0])
    assert abs(x) < 0.2 and abs(z - 2.0) < 0.05  # the square returns to its start at 2 m
    assert "100%" in out.stderr  # progress was shown


def test_run_with_seed_and_duration():
    out = cli("run", "--script", "takeoff", "--controller", "seed", "--duration", "2", *QUIET)
    assert out.returncode == 0, out.stderr
    assert "sim time        2.00 s" in out.stdout and "controller seed" in out.stdout


def _one_line_error(out: subprocess.CompletedProcess, *words: str) -> None:
    assert out.returncode == 2
    assert "Traceback" not in out.stderr
    lines = [line for line in out.stderr.splitlines() if line.strip() and "pybullet build time" not in line]
    assert len(lines) == 1, out.stderr
    for w in words:
        assert w in lines[0]


def test_unknown_scenario():
    _one_line_error(cli("run", "--script", "barrel-roll"), "unknown scenario", "square")


def test_unparsable_script_names_line(tmp_path):
    bad = tmp_path / "bad.qscript"
    bad.write_text("z_mode height\n2.0 linear.z=0\n1.0 linear.x=one\n")
    _one_line_error(cli("run", "--script", str(bad)), "line 3", "linear.x")


def test_missing_script_file(tmp_path):
    _one_line_error(cli("run", "--script", str(tmp_path / "none.qscript")), "not found")


def test_rate_that_does_not_divide():
    _one_line_error(cli("run", "--script", "hover", "--control-hz", "100", *QUIET), "does not divide")


def test_missing_urdf(tmp_path):
    _one_line_error(cli("run", "--script", "hover", "--urdf", str(tmp_path / "ghost.urdf"), *QUIET), "URDF not found")


@pytest.mark.parametrize("command", ["run", "fly", "scenarios", "evaluate", "bench", "info", "recover"])
def test_help_on_every_command(command):
    out = cli(command, "--help")
    assert out.returncode == 0 and "usage:" in out.stdout and len(out.stdout.splitlines()) > 3


def test_fly_without_display_flies_demo_and_says_so():
    out = cli("fly", "--duration", "3", *QUIET)
    assert out.returncode == 0, out.stderr
    assert "No display found" in out.stdout and "sim time        3.00 s" in out.stdout


def test_fly_without_display_keeps_no_demo_under_a_name_meant_for_a_flight_by_hand(tmp_path):
    """`fly --out my_flights/by_hand.mcap` with no display recorded the scripted demo there, which
    then passed `check` as a flight by hand; it now refuses and says how to record a script."""
    out = cli("fly", "--cameras", "none", "--out", str(tmp_path / "by_hand.mcap"))
    _one_line_error(out, "would hold the scripted demo")
    assert "run --script NAME --out" in out.stderr and not (tmp_path / "by_hand.mcap").exists()
    # a folder is no such name: the demo lands there under a dated name that says what it is
    out = cli("fly", "--cameras", "none", "--duration", "2", "--out", str(tmp_path / "flights"))
    assert out.returncode == 0 and "Recording the scripted demo 'figure8'" in out.stdout, out.stderr
    assert [p.name.endswith("_figure8_cascade.mcap") for p in (tmp_path / "flights").iterdir()] == [True]
    out = cli("fly", "--cameras", "none", "--duration", "2", "--no-record")
    assert out.returncode == 0 and "Flying the scripted demo 'figure8'" in out.stdout, out.stderr


def test_fly_fleet_without_a_display_says_what_to_do(tmp_path):
    """Unlike `fly` (above: it flies the scripted demo headless), `fly --fleet` refuses."""
    (tmp_path / "f.toml").write_text(WINDOW_FLEET)
    out = cli("fly", "--fleet", str(tmp_path / "f.toml"))
    assert out.returncode == 2 and "fly --fleet needs a display" in out.stderr and "run --fleet" in out.stderr


def test_scenarios_lists_builtins():
    out = cli("scenarios")
    assert out.returncode == 0 and "figure8" in out.stdout and "hover" in out.stdout


def test_gui_without_display_is_a_clear_error():
    _one_line_error(cli("run", "--script", "hover", "--gui", *QUIET), "needs a display")


def test_a_script_with_a_long_name_records_under_a_name_the_file_system_takes(tmp_path):
    """The dated name was the script's name and more: past 255 bytes, a traceback (ENAMETOOLONG)."""
    script = tmp_path / ("a" * 240 + ".qscript")
    script.write_text("1.0 linear.z=0.5\n")
    out = cli("run", "--script", str(script), "--cameras", "none", "--out", str(tmp_path / "runs"))
    assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr
    (recording,) = (tmp_path / "runs").iterdir()
    assert len(recording.name.encode()) <= 255 and recording.name.endswith("_cascade.mcap"), recording.name
    assert "a" * 100 in recording.name  # as much of the script's name as fits


@pytest.mark.parametrize(
    ("option", "said"),
    [
        ("--urdf", "vehicle URDF is a folder: "),
        ("--world", "world file is a folder: "),
        ("--out", "it is a file, not a folder"),
    ],
)
def test_a_folder_for_a_file_or_a_file_for_a_folder_is_named_so(tmp_path, option, said):
    """A folder given as the URDF or world said 'not found'; a file in the place of the recording
    folder said 'cannot create the recording folder ...: File exists'."""
    (tmp_path / "taken.mcap").write_bytes(b"")
    value = str(tmp_path / "taken.mcap" / "run.mcap") if option == "--out" else str(tmp_path)
    out = cli("run", "--script", "takeoff", "--cameras", "none", option, value)
    _one_line_error(out, said)
