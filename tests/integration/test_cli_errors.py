"""Bad command lines and files: one line on stderr, exit code 2, never a traceback.

Each case is a mistake a user makes; most run in-process through the CLI's `main` (fast), a
few in a real process where the process itself matters (a closed pipe)."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from quadsim.apps.cli import main
from quadsim.control.gate import CommandGate
from quadsim.core.types import Twist, ZMode
from quadsim.vehicle.params import DEFAULT_URDF, load_vehicle
from tests.helpers import RECORDINGS, ROOT

QUICK = ["--cameras", "none", "--no-record"]


def run_cli(capsys, *argv: str) -> tuple[int, str, str]:
    try:
        code = main(list(argv))
    except SystemExit as exc:  # argparse's own exit
        code = exc.code if isinstance(exc.code, int) else 1
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code: int, err: str, *expected: str) -> None:
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2, err
    assert len(lines) == 1, f"expected one line, got:\n{err}"
    assert "Traceback" not in err
    for word in expected:
        assert word in lines[0], lines[0]


@pytest.fixture
def world_file(tmp_path):
    def make(floor: str, landmark: str = "") -> Path:
        path = tmp_path / "w.toml"
        if landmark.startswith("landmark ="):  # a top-level key: before the [floor] table
            path.write_text(f"{landmark}\n[floor]\n{floor}\n")
        else:
            path.write_text(f"[floor]\n{floor}\n{landmark}")
        return path

    return make


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["run", "--script", "hover", "--timeout", "inf"], "--timeout"),
        (["run", "--script", "hover", "--timeout", "1e308"], "--timeout"),
        (["run", "--script", "hover", "--duration", "inf"], "--duration"),
        (["run", "--script", "hover", "--duration", "nan"], "--duration"),
        (["run", "--script", "hover", "--camera-hz", "0"], "--camera-hz"),
        (["run", "--script", "hover", "--camera-hz", "-30"], "--camera-hz"),
        (["run", "--script", "hover", "--timeout", "0.01", *QUICK], "shorter than the input period"),
        (["run", "--script", "hover", "--physics-hz", "99999999"], "--physics-hz"),
        (["run", "--script", "hover", "--physics-hz", "9973", *QUICK], "does not divide"),
        # the rate at fault is a default the user never typed: it says so (it blamed control_hz=240)
        (["run", "--script", "hover", "--physics-hz", "241", *QUICK], "--control-hz 240 (its default) does not divide"),
        (["run", "--script", "hover", "--physics-hz", "480", "--state-hz", "7", *QUICK], "--state-hz 7 does not"),
        (["run", "--script", "hover", "--render-workers", "-1"], "--render-workers"),
        (["bench", "--steps", "0"], "--steps"),
        (["bench", "--steps", "-5"], "--steps"),
        (["bench", "--repeats", "0"], "--repeats"),
        (["replay", "x.mcap", "--speed", "100"], "--speed"),
        (["replay", "x.mcap", "--speed", "0.1"], "--speed"),
        (["check", "x.mcap", "--tolerance-m", "-1"], "--tolerance-m"),
        (["check", "x.mcap", "--tolerance-m", "nan"], "--tolerance-m"),
        (["run", "--script", "nosuchscenario"], "unknown scenario"),
        (["run", "--script", "hover", "--wind", "3", *QUICK], "--wind must look like SPEED,FROM_DEG"),
        (["run", "--script", "hover", "--wind", "3,east", *QUICK], "--wind must look like SPEED,FROM_DEG"),
        (["run", "--script", "hover", "--wind", "80,90", *QUICK], "wind speed 80 m/s is outside"),
        (["run", "--script", "hover", "--wind", "inf,90", *QUICK], "--wind must be finite"),
        (["run", "--script", "hover", "--turbulence", "gale"], "--turbulence"),
        (["run", "--script", "hover", "--seed", "-1"], "--seed"),
        (["run", "--script", "hover", "--seed", "1.5"], "--seed"),
    ],
)
def test_bad_option_values(capsys, argv, expected):
    code, _, err = run_cli(capsys, *argv)
    assert_one_line_error(code, err, expected)
    assert len(err) < 400  # a short message, not a list of every divisor


@pytest.mark.parametrize(
    ("floor", "landmark", "expected"),
    [
        ("size_m = 1e30", "", "size_m"),
        ("size_m = nan", "", "size_m"),
        ('size_m = "big"', "", "size_m"),
        ("friction = -1", "", "friction"),
        (
            "size_m = 40.0",
            '[[landmark]]\nname = "x"\nshape = "box"\nposition_m = [1, 0, 1]\nsize_m = [1, 1, nan]\ncolor_rgba = [1, 0, 0, 1]',
            "size_m",
        ),
        (
            "size_m = 40.0",
            '[[landmark]]\nname = "x"\nshape = "box"\nposition_m = ["a", 0, 1]\nsize_m = [1, 1, 1]\ncolor_rgba = [1, 0, 0, 1]',
            "position_m",
        ),
        ("size_m = 40.0", "landmark = 5", "landmark"),
    ],
)
def test_bad_world_files(capsys, world_file, floor, landmark, expected):
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--world", str(world_file(floor, landmark)), *QUICK)
    assert_one_line_error(code, err, expected)


def test_a_world_file_that_is_not_utf8(capsys, tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes("[floor]\n# caf\xe9\nsize_m = 40.0\n".encode("latin-1"))
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--world", str(path), *QUICK)
    assert_one_line_error(code, err, "UTF-8")


def _vehicle_copy(tmp_path: Path, urdf_edit=None, params_edit=None) -> Path:
    urdf = tmp_path / "v.urdf"
    params = tmp_path / "v.params.toml"
    text = DEFAULT_URDF.read_text()
    urdf.write_text(urdf_edit(text) if urdf_edit else text)
    ptext = DEFAULT_URDF.with_suffix(".params.toml").read_text()
    params.write_text(params_edit(ptext) if params_edit else ptext)
    return urdf


def test_a_urdf_with_a_missing_mesh(capsys, tmp_path):
    urdf = _vehicle_copy(
        tmp_path,
        urdf_edit=lambda t: t.replace(
            "<visual>", '<visual><geometry><mesh filename="meshes/nope.stl"/></geometry></visual><visual>', 1
        ),
    )
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--urdf", str(urdf), *QUICK)
    assert_one_line_error(code, err, "mesh file not found", "nope.stl")


def test_bad_types_in_the_vehicle_parameters(capsys, tmp_path):
    urdf = _vehicle_copy(tmp_path, params_edit=lambda t: t.replace("max_thrust_n = ", 'max_thrust_n = "x" # ', 1))
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--urdf", str(urdf), *QUICK)
    assert_one_line_error(code, err, "max_thrust_n")
    urdf.with_suffix(".params.toml").write_bytes(b"[rotors]\n# \xff\xfe\n")
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--urdf", str(urdf), *QUICK)
    assert_one_line_error(code, err, "UTF-8")


def test_a_script_with_a_byte_order_mark_flies(capsys, tmp_path):
    script = tmp_path / "bom.qscript"
    script.write_bytes("\ufeffz_mode height\n1.0 linear.z=0\n".encode())
    code, out, err = run_cli(capsys, "run", "--script", str(script), *QUICK)
    assert code == 0, err
    assert "z-mode height" in out  # the first line was read as the z-mode, not refused


@pytest.mark.parametrize("name", ["plot.txt", "plot"])
def test_plot_to_a_file_without_an_image_type(capsys, tmp_path, name):
    code, _, err = run_cli(capsys, "replay", "x.mcap", "--plot", str(tmp_path / name))
    assert_one_line_error(code, err, "--plot")


def test_plot_to_a_folder(capsys, tmp_path):
    code, _, err = run_cli(capsys, "replay", "x.mcap", "--plot", str(tmp_path))
    assert_one_line_error(code, err, "is a folder")


def test_outputs_where_nothing_can_be_written(capsys, tmp_path):
    code, _, err = run_cli(capsys, "replay", "x.mcap", "--mp4", "/proc/quadsim-videos")
    assert_one_line_error(code, err, "--mp4")
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--cameras", "none", "--out", "/proc/quadsim-rec")
    assert_one_line_error(code, err, "/proc/quadsim-rec")
    long_name = tmp_path / ("x" * 300 + ".mcap")
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--cameras", "none", "--out", str(long_name))
    assert_one_line_error(code, err, "too long")


def test_a_recording_that_exists_is_refused_before_anything_is_built(capsys, monkeypatch, tmp_path):
    """Refused in one line before the world and the vehicle are built (a first compile of the
    flight core, said and waited for, came before the refusal)."""
    import quadsim.sim.fleet

    def built(*args, **kwargs):
        raise AssertionError("the vehicle was built before the refusal")

    monkeypatch.setattr(quadsim.sim.fleet, "Drone", built)
    existing = tmp_path / "taken.mcap"
    existing.write_bytes(b"mine")
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--cameras", "none", "--out", str(existing))
    assert_one_line_error(code, err, f"{existing} already exists; choose another --out")
    assert existing.read_bytes() == b"mine"


def test_fly_gui_without_a_display(capsys, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    code, _, err = run_cli(capsys, "fly", "--gui")
    assert_one_line_error(code, err, "--gui needs a display")


@pytest.mark.parametrize("reader", ["head -n 1", "true"])
def test_output_piped_into_a_reader_that_stops_is_quiet(reader):
    """`quadsim scenarios | head -n 1`: the closed pipe ends the program quietly."""
    proc = subprocess.run(
        f"{sys.executable} {ROOT / 'main.py'} scenarios | {reader}",
        shell=True,
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert "Traceback" not in proc.stderr and "BrokenPipe" not in proc.stderr, proc.stderr
    assert proc.stderr == ""


def test_clamping_does_not_overflow():
    gate = CommandGate(load_vehicle().limits, ZMode.VELOCITY, None)
    limit = gate.limits.max_horizontal_speed_mps
    clamped = gate.clamp(Twist(linear_x=1.7e308, linear_y=1.7e308))
    assert clamped.linear_x == pytest.approx(limit / math.sqrt(2)) and clamped.linear_y == pytest.approx(
        limit / math.sqrt(2)
    )
    clamped = gate.clamp(Twist(linear_x=-1.7e308, linear_y=1e-300))
    assert clamped.linear_x == pytest.approx(-limit) and abs(clamped.linear_y) < 1e-6


def test_a_z_mode_override_that_cannot_take_off_is_refused(capsys):
    code, _, err = run_cli(capsys, "run", "--script", "square", "--z-mode", "velocity", *QUICK)
    assert_one_line_error(code, err, "never take off")


def test_a_z_mode_override_that_flies_is_warned_about(capsys):
    code, out, err = run_cli(capsys, "run", "--script", "climb", "--z-mode", "height", "--duration", "1", *QUICK)
    assert code == 0 and "written for velocity z-mode" in err and "z-mode height" in out


def test_the_api_takes_the_scripts_z_mode():
    """`Simulator(SimConfig(), ScriptedDriver(script))`: the script's z_mode line is obeyed."""
    from quadsim import SimConfig, Simulator
    from quadsim.drivers.scripted import ScriptedDriver, load_script

    with Simulator(SimConfig(), ScriptedDriver(load_script("hover"))) as sim:
        assert sim.gate.z_mode is ZMode.HEIGHT
        state = sim.run_for(6.0)
        assert abs(state.position_m[2] - 2.0) < 0.1  # height mode, linear.z = 0: hold 2 m
    with Simulator(SimConfig(z_mode=ZMode.VELOCITY), ScriptedDriver(load_script("climb"))) as sim:
        assert sim.gate.z_mode is ZMode.VELOCITY  # an explicit setting wins


def test_an_unrecorded_headless_run_renders_no_camera(capsys, monkeypatch):
    from quadsim.sensors import rig

    def no_rendering(*args, **kwargs):
        raise AssertionError("rendered a frame nobody consumes")

    monkeypatch.setattr(rig.CameraRig, "render", no_rendering)
    code, out, err = run_cli(
        capsys, "run", "--script", "hover", "--no-record", "--render-workers", "0", "--duration", "1"
    )
    assert code == 0, err
    assert "cameras none" in out


@pytest.mark.parametrize("size", ["big", "10x10", "1280x"])
def test_a_bad_window_size(capsys, size):
    code, _, err = run_cli(
        capsys, "replay", str(ROOT / "tests" / "recordings" / "square_cascade.mcap"), "--window", size
    )
    assert_one_line_error(code, err, "--window")


def test_a_start_pose_far_away_is_refused():
    from quadsim import ConfigError, SimConfig, StartPose

    with pytest.raises(ConfigError, match="beyond"):
        SimConfig(start=StartPose(1e300, 0.0, 0.0))


def test_a_negative_wind_reads_as_a_value_and_says_how_to_turn_it(capsys):
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--wind", "-5,90", *QUICK)
    assert_one_line_error(code, err, "wind speed -5 m/s is outside [0, 50] m/s", "opposite side: 5,270")


def test_camera_options_nothing_would_show_are_refused(capsys):
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--camera-size", "64x48", "--no-record")
    assert_one_line_error(code, err, "--camera-size with --no-record", "nothing would show the frames")
    code, out, _ = run_cli(capsys, "run", "--script", "hover", "--duration", "0.2", *QUICK)
    assert code == 0 and "cameras none" in out  # asking for none is fine


def test_a_bad_world_file_is_the_only_line(capsys, tmp_path):
    """Checked before the run says what it flies: no 'flying ...' header above the error."""
    world = tmp_path / "w.toml"
    world.write_text("[floor]\nsize_m = 'big'\n")
    code, out, err = run_cli(capsys, "run", "--script", "hover", "--world", str(world), *QUICK)
    assert code == 2 and out == "" and err.count("\n") == 1, (out, err)


def test_replay_foxglove_before_the_file_serves_the_file():
    """`replay --foxglove FILE.mcap`: the option's value is optional, the file is not swallowed."""
    from quadsim.apps.cli import _normalise_argv, build_parser
    from quadsim.live import FOXGLOVE_DEFAULT_ENDPOINT

    args = build_parser().parse_args(_normalise_argv(["replay", "--foxglove", "flight.mcap", "--headless"]))
    assert args.file == Path("flight.mcap") and args.foxglove == FOXGLOVE_DEFAULT_ENDPOINT
    args = build_parser().parse_args(_normalise_argv(["replay", "--foxglove", "0.0.0.0:9000", "flight.mcap"]))
    assert args.file == Path("flight.mcap") and args.foxglove == "0.0.0.0:9000"
    args = build_parser().parse_args(_normalise_argv(["run", "--script", "hover", "--wind", "-5,90"]))
    assert args.wind == "-5,90"


def test_sweep_help_names_its_default_folder_plainly(capsys):
    with pytest.raises(SystemExit):
        main(["sweep", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "/sweeps/NAME; set QUADSIM_RECORDINGS to change it)" in text


def test_an_unknown_option_points_to_its_commands_help(capsys):
    code, _, err = run_cli(capsys, "run", "--nope")
    assert_one_line_error(code, err, "unrecognized arguments: --nope", "run --help)")
    code, _, err = run_cli(capsys, "--nope")
    assert_one_line_error(code, err, "unrecognized arguments: --nope")
    assert "run --help" not in err
    code, _, err = run_cli(capsys, "run", "--physics-hz", "100000")
    assert_one_line_error(code, err, "within 1..10000")  # the limit the simulator has (it said 100000)


@pytest.mark.parametrize(
    "options,said",
    [
        (["--camera-hz", "7"], "--camera-hz 7: does not divide the physics rate 240 Hz"),
        (["--cameras", "front,front"], "--cameras: front is named twice"),
        (["--cameras", ""], "--cameras: say which"),  # it flew both cameras
    ],
)
def test_camera_options_are_refused_before_the_flight_says_anything(capsys, tmp_path, options, said):
    code, out, err = run_cli(capsys, "run", "--script", "hover", "--out", str(tmp_path / "r"), *options)
    assert_one_line_error(code, err, said)
    assert "flying" not in out and not (tmp_path / "r").exists()


def test_what_a_user_trial_found_last_is_refused_in_one_line(capsys, tmp_path):
    """A ROS 2 option with no ROS 2 bridge, a non-image floor texture, a script field given twice,
    --mp4 to another video type (it made a folder vid.avi/), --plot over a file (it overwrote)."""
    code, _, err = run_cli(
        capsys, "run", "--script", "hover", "--ros-namespace", "x", "--no-record", "--cameras", "none"
    )
    assert_one_line_error(code, err, "--ros-namespace is for the ROS 2 bridge")
    world = tmp_path / "w.toml"
    (tmp_path / "tile.png").write_text("not an image\n")
    world.write_text('[floor]\ntexture = "tile.png"\n')
    code, _, err = run_cli(
        capsys, "run", "--world", str(world), "--script", "hover", "--no-record", "--cameras", "none"
    )
    assert_one_line_error(code, err, "texture", "is not a PNG, JPEG or BMP image")
    (tmp_path / "twice.qscript").write_text("2 linear.z=1 linear.z=-1\n")
    code, _, err = run_cli(capsys, "run", "--script", str(tmp_path / "twice.qscript"), "--no-record")
    assert_one_line_error(code, err, "twice.qscript, line 1: linear.z is given twice")
    recording = str(RECORDINGS / "climb_cascade.mcap")
    code, _, err = run_cli(capsys, "replay", recording, "--headless", "--mp4", str(tmp_path / "vid.avi"))
    assert_one_line_error(code, err, "give a folder or NAME.mp4")
    assert not (tmp_path / "vid.avi").exists()
    (tmp_path / "p.png").write_bytes(b"keep")
    code, _, err = run_cli(capsys, "replay", recording, "--headless", "--plot", str(tmp_path / "p.png"))
    assert_one_line_error(code, err, "p.png already exists; choose another --plot")
    assert (tmp_path / "p.png").read_bytes() == b"keep"


def test_live_timeout_without_a_live_input_is_one_line(capsys) -> None:
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--live-timeout", "0.2", "--no-record")
    assert_one_line_error(code, err, "--live-timeout is for a live input")


@pytest.mark.parametrize("driver", ["", "x11"], ids=["sdl-chooses", "sdl-videodriver-x11"])
@pytest.mark.parametrize("command", [["fly", "--cameras", "none"], ["replay", str(RECORDINGS / "climb_cascade.mcap")]])
def test_a_display_that_does_not_answer_is_one_line_not_an_unseen_window(command, driver, tmp_path):
    """DISPLAY names an X server that is not there (a stale one from an SSH session, an Xvfb that
    died): SDL falls back to its offscreen driver, and the window used to fly unseen until killed;
    with SDL_VIDEODRIVER=x11, SDL's error came out as a traceback."""
    from tests.helpers.cli import bare_env, run_main

    number = next(n for n in range(990, 1100) if not Path(f"/tmp/.X11-unix/X{n}").exists())
    env = bare_env(DISPLAY=f":{number}", XDG_RUNTIME_DIR=str(tmp_path), QUADSIM_RECORDINGS=str(tmp_path / "rec"))
    if driver:
        env["SDL_VIDEODRIVER"] = driver
    done = run_main(*command, env=env, timeout=120)
    assert_one_line_error(
        done.returncode, done.stderr, f"cannot open a window: no display answers on DISPLAY=:{number}"
    )
    said = "(SDL: x11 not available)" if driver else "(SDL fell back to its offscreen driver, which shows nothing)"
    assert said in done.stderr and not (tmp_path / "rec").exists()
