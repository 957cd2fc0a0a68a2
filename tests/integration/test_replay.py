"""Replay: playback (window and headless), re-simulation, and recordings as regression tests."""

import dataclasses
import math
import re
import subprocess
import sys
from pathlib import Path

import cv2
import pygame
import pytest
from mcap.writer import Writer

from quadsim import QuadsimError, SimConfig, ZMode
from quadsim.apps.replay_export import export_mp4
from quadsim.apps.window.replay import ReplayApp
from quadsim.apps.window.teleop import TeleopApp, TeleopOptions
from quadsim.core.invocation import install_extra
from quadsim.recording.flight import load_flight, load_flights
from quadsim.recording.reader import RecordingReader
from quadsim.session.outputs import OutputOptions
from quadsim.session.pacing import FixedStepPacer
from quadsim.session.resim import resimulate
from tests.helpers import RECORDINGS as RECORDINGS_DIR
from tests.helpers import ROOT
from tests.helpers.cli import bare_env, run_main
from tests.helpers.recording import SHIPPED_RECORDINGS, record_flight
from tests.integration.test_teleop import APPS

RECORDINGS = SHIPPED_RECORDINGS


def cli(*args):
    return run_main(*args, cwd=ROOT, env=bare_env(SDL_VIDEODRIVER="dummy"))


# --- recordings as regression tests --------------------------------------------------------------


def test_shipped_recordings_are_small_and_cover_both_controllers_and_teleop():
    assert len(RECORDINGS) >= 3
    assert all(p.stat().st_size < 1_000_000 for p in RECORDINGS)
    drivers = {load_flight(p).description.driver_name for p in RECORDINGS}
    controllers = {load_flight(p).description.controller.kind.value for p in RECORDINGS}
    assert {"scripted", "keyboard"} <= drivers and {"cascade", "seed"} <= controllers


# each shipped recording re-flies as a test item of its own: the quadsim pytest plugin collects
# tests/recordings/*.mcap (pyproject.toml's quadsim_recordings; tests/unit/test_pytest_plugin.py tests it)


@pytest.mark.parametrize("shape", list(APPS))
def test_fresh_interactive_recording_reflies_to_zero(shape, tmp_path):
    """Tab switches the flown vehicle's z-mode: the recording keeps the switch under its name
    (a fleet's, not the others'), so the run re-flies to zero (it was once a run event in a
    fleet, and the height commands after it re-flew as climbs)."""
    app = APPS[shape](tmp_path)
    flown, *others = app.session.fleet
    plan = {2: pygame.K_w, 40: pygame.K_TAB, 50: pygame.K_UP, 51: pygame.K_d}

    def events(a):
        if a.frame_count in plan:
            pygame.event.post(
                pygame.event.Event(pygame.KEYDOWN, key=plan[a.frame_count], mod=0, unicode="", scancode=0)
            )

    app.run(max_frames=120, before_frame=events)
    assert app.sim.gate.z_mode is ZMode.HEIGHT
    app.close()
    flights = load_flights(app.recordings[0])
    with RecordingReader(app.recordings[0]) as reader:  # a fleet's recording keeps the run's own apart
        run_events = reader.events
    assert [e[1:] for e in sorted({*run_events, *flights[flown].events})] == [
        ("recording", "started"),
        ("takeoff", "climbing from the ground"),
        ("z_mode", "height"),
        ("recording", "stopped"),
    ]
    for name in others:
        assert not [value for _, kind, value in flights[name].events if kind == "z_mode"], name
    report = resimulate(flights, out=tmp_path / "again")
    assert report.position.max_error == 0.0 and report.attitude.max_error == 0.0
    assert report.fleet_size == (len(flights) if others else 0)
    assert report.new_recording is not None and all(f.states for f in load_flights(report.new_recording).values())


def test_check_on_unusable_files_exits_2(tmp_path):
    bad = tmp_path / "cut.mcap"
    data = (ROOT / "tests" / "recordings" / "square_cascade.mcap").read_bytes()
    bad.write_bytes(data[: len(data) // 3])
    out = cli("check", bad)
    # the re-flight's own refusal (session/resim.py) names recover as the command that ran: a clone's
    assert out.returncode == 2 and "ERROR" in out.stdout and "main.py recover" in out.stdout
    assert "Traceback" not in out.stderr


# --- re-simulation refuses what it cannot fly --------------------------------------------------------


def _foreign(path: Path) -> Path:
    with open(path, "wb") as fh:
        w = Writer(fh)
        w.start("", "someone else")
        sid = w.register_schema("Blob", "jsonschema", b"{}")
        cid = w.register_channel("/weather", "json", sid)
        w.add_message(cid, 0, b"{}", 0)
        w.finish()
    return path


def test_resim_refuses_clearly(tmp_path):
    with pytest.raises(QuadsimError, match="not a quadsim recording"):
        resimulate(load_flight(_foreign(tmp_path / "f.mcap")))
    # a flight without a command (a window closed at once) is a vehicle at rest: it re-flies
    path = tmp_path / "no_commands.mcap"
    record_flight(path, cameras=False, script="silence 1.0\n")
    silent = resimulate(load_flight(path), record=False)  # not into the checkout's recordings/
    assert silent.position.max_error == 0.0 and silent.attitude.max_error == 0.0
    assert silent.states_compared >= 60
    # a window closed (or signalled) before its first step: nothing flown, nothing to re-fly
    app = TeleopApp(SimConfig(), OutputOptions(out=tmp_path / "at_once.mcap", cameras=()), TeleopOptions())
    app.close()
    with pytest.raises(QuadsimError, match="nothing was flown"):
        resimulate(load_flight(tmp_path / "at_once.mcap"))
    checked = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "check", str(tmp_path / "at_once.mcap")],
        capture_output=True,
        text=True,
    )
    assert checked.returncode == 0, checked.stdout + checked.stderr  # `check recordings/` is not failed by it
    assert "nothing was flown" in checked.stdout
    app = TeleopApp(
        SimConfig(),
        OutputOptions(out=tmp_path / "mid", record=False, cameras=()),
        TeleopOptions(),
        pacer=FixedStepPacer(240, 1 / 30),
    )
    app.run(max_frames=10)
    app.toggle_recording()  # started mid-flight
    app.run(max_frames=20)
    app.close()
    with pytest.raises(QuadsimError, match="started mid-flight"):
        resimulate(load_flight(app.recordings[0]))


def test_cli_resim_on_damaged_file(tmp_path):
    bad = tmp_path / "cut.mcap"
    data = (ROOT / "tests" / "recordings" / "climb_cascade.mcap").read_bytes()
    bad.write_bytes(data[: len(data) // 2])
    out = cli("replay", bad, "--resim")
    assert out.returncode == 2 and "cut short" in out.stderr and "Traceback" not in out.stderr


# --- headless playback ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def with_cameras(tmp_path_factory):
    path = tmp_path_factory.mktemp("cams") / "cams.mcap"
    record_flight(path)
    return path


def test_headless_summary_video_and_plot(with_cameras, tmp_path):
    out = cli("replay", with_cameras, "--headless", "--mp4", tmp_path / "videos", "--plot", tmp_path / "plot.png")
    assert out.returncode == 0, out.stderr
    assert "duration    3.00 s" in out.stdout and "camera      front: 90 frames" in out.stdout
    for cam in ("front", "floor"):
        path = tmp_path / "videos" / f"cams_{cam}.mp4"
        video = cv2.VideoCapture(str(path))
        # VP9 in MP4, which browsers play (OpenCV's bundled FFmpeg has no H.264 encoder)
        assert int(video.get(cv2.CAP_PROP_FOURCC)).to_bytes(4, "little").lower() in (b"vp09", b"vp90")
        count = 0
        while video.read()[0]:
            count += 1
        assert count == 90 and video.get(cv2.CAP_PROP_FPS) == pytest.approx(30, abs=0.5)
        assert b"ftyp" in path.read_bytes()[:16]  # an MP4 container
    plot = cv2.imread(str(tmp_path / "plot.png"))
    assert plot.shape == (800, 1400, 3) and plot.std() > 10
    # the flown track is drawn in red (#d62728) in the left panel, the commands dashed blue on the right
    left, right = plot[:, :560], plot[:, 600:]
    red = (abs(left[..., 2].astype(int) - 0xD6) < 30) & (left[..., 1] < 80) & (left[..., 0] < 80)
    blue = (abs(right[..., 0].astype(int) - 0xB4) < 30) & (abs(right[..., 2].astype(int) - 0x1F) < 40)
    assert red.sum() > 50 and blue.sum() > 200


def _frame_count(path: Path) -> int:
    video, count = cv2.VideoCapture(str(path)), 0
    while video.read()[0]:
        count += 1
    return count


def test_the_camera_streams_encode_side_by_side_as_each_would_alone(with_cameras, tmp_path):
    """Both streams at once (a core each) give the same bytes as one stream encoded on its own,
    and the progress counts every frame once, in order."""
    flight = load_flight(with_cameras)
    calls: list[tuple[int, int]] = []
    videos = export_mp4(flight, tmp_path / "both", progress=lambda done, total: calls.append((done, total)))
    assert [(v.path.name, v.frames, v.of) for v in videos] == [("cams_floor.mp4", 90, 90), ("cams_front.mp4", 90, 90)]
    assert calls == [(n, 180) for n in range(1, 181)]
    alone = dataclasses.replace(flight, frames={"front": flight.frames["front"]})
    (single,) = export_mp4(alone, tmp_path / "alone")
    assert single.path.read_bytes() == (tmp_path / "both" / "cams_front.mp4").read_bytes()


def test_a_stop_ends_every_stream_as_a_shorter_whole_video(with_cameras, tmp_path):
    flight = load_flight(with_cameras)
    asked: list[int] = []
    videos = export_mp4(flight, tmp_path, progress=lambda done, _: asked.append(done), stop=lambda: len(asked) >= 20)
    assert all(1 <= v.frames < v.of == 90 for v in videos) and sum(v.frames for v in videos) <= 21
    for v in videos:
        assert _frame_count(v.path) == v.frames  # released: a whole file, each frame it says it has
        assert "stopped" in v.line() and f"the first {v.frames} of 90 frames" in v.line()


def test_plot_without_matplotlib_says_how_to_get_it(with_cameras, tmp_path, monkeypatch, capsys):
    import builtins

    from quadsim.apps.flight_plot import export_plot
    from quadsim.errors import QuadsimError

    real_import = builtins.__import__

    def no_matplotlib(name, *args, **kwargs):
        if name.startswith("matplotlib"):
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_matplotlib)
    with pytest.raises(QuadsimError, match=re.escape(install_extra("plot"))):
        export_plot(load_flight(with_cameras), tmp_path / "p.png")
    # `replay --mp4 --plot` says so before encoding a frame (it used to, after minutes of videos)
    from quadsim.apps.cli import main

    assert (
        main(["replay", str(with_cameras), "--mp4", str(tmp_path / "videos"), "--plot", str(tmp_path / "p.png")]) == 2
    )
    assert install_extra("plot") in capsys.readouterr().err
    videos = tmp_path / "videos"
    assert not (videos.exists() and list(videos.iterdir())) and not (tmp_path / "p.png").exists()


def test_replay_without_display_prints_summary(with_cameras):
    out = cli("replay", with_cameras)
    assert out.returncode == 0 and "No display found" in out.stdout and "duration" in out.stdout


def test_playback_of_a_foreign_file_shows_what_is_there(tmp_path):
    out = cli("replay", _foreign(tmp_path / "f.mcap"), "--headless")
    assert out.returncode == 0 and "no quadsim metadata" in out.stdout and "states      none" in out.stdout


# --- the playback window ---------------------------------------------------------------------------


def key(k):
    pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=k, mod=0, unicode="", scancode=0))


def test_playback_window_controls(with_cameras):
    app = ReplayApp(load_flight(with_cameras), (960, 540), frame_s=0.1)
    app.run(max_frames=5)
    assert app.t_ns == pytest.approx(0.5e9, abs=1e6) and app.playing
    key(pygame.K_SPACE)
    app.run(max_frames=10)
    paused_at = app.t_ns
    assert not app.playing and paused_at == pytest.approx(0.5e9, abs=1e6)
    key(pygame.K_PERIOD)  # one state forward: 1/60 s later
    app.run(max_frames=11)
    assert app.t_ns - paused_at == pytest.approx(1e9 / 60, abs=1e6)
    for _ in range(8):
        key(pygame.K_UP)
    app.run(max_frames=12)
    assert app.speed == 16.0
    for _ in range(9):
        key(pygame.K_DOWN)
    app.run(max_frames=13)
    assert app.speed == 0.25
    # a click on the timeline seeks there
    bar = app.view.layout(app.screen.get_size())["timeline"]
    pygame.event.post(
        pygame.event.Event(pygame.MOUSEBUTTONDOWN, button=1, pos=(bar.x + bar.width * 3 // 4, bar.centery))
    )
    app.run(max_frames=14)
    assert app.t_ns / 1e9 == pytest.approx(0.75 * 3.0, abs=0.05)
    key(pygame.K_LEFT)  # 5 s back: clamps at the start
    app.run(max_frames=15)
    assert app.t_ns == 0
    # loop: playing past the end wraps
    key(pygame.K_l)
    key(pygame.K_END)
    key(pygame.K_SPACE)
    app.run(max_frames=20)
    assert app.loop and app.playing and app.t_ns < 1e9
    model = app.model()
    assert set(model.frames) == {"front", "floor"} and len(model.track) > 10
    pygame.image.save(app.screen, "/tmp/quadsim_replay_test.png")
    app.close()


#: a shipped recording of each shape, and what C says in its window once it has gone round
FOLLOWED = {
    "alone": ("square_cascade.mcap", "one vehicle in this recording: nothing else to follow"),
    "fleet of 3": ("fleet_trio_wind.mcap", "following alpha (it recorded no cameras)"),
}


@pytest.mark.parametrize("shape", list(FOLLOWED))
def test_c_in_the_replay_window_follows_each_vehicle_in_turn(shape):
    """The replay window of a recording: C follows the next vehicle (its HUD's state and
    cameras, the others on the map), in the fleet's order and round again; alone, there is no
    other to follow, and it says so."""
    recording, said = FOLLOWED[shape]
    flights = load_flights(RECORDINGS_DIR / recording)
    first, *rest = flights
    with ReplayApp(flights[first], (640, 360), frame_s=0.1, others={n: flights[n] for n in rest}) as app:
        app.seek(5.0)
        followed = []
        for _ in flights:
            model = app.model()
            followed.append(model.cameras_of)
            assert model.state == flights[model.cameras_of].state_at(app.t_ns)
            assert [n for n, *_ in model.others] == [n for n in flights if n != model.cameras_of]
            pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_c, mod=0, unicode="c", scancode=0))
            app.run(max_frames=app.frame_count + 1)
        assert followed == list(flights) and app.model().cameras_of == first
        assert said in app.model().warnings


def test_the_plot_shades_the_stretch_flown_in_height_mode():
    """Switches at steps whose log time is not a whole nanosecond (1 / 240 s): the shaded span is
    the one between them, not the one after the switch back."""
    from quadsim.apps.flight_plot import _height_spans

    flight = load_flight(ROOT / "tests" / "recordings" / "keyboard_session_cascade.mcap")
    flight.events = [(1441, "z_mode", "height"), (2001, "z_mode", "velocity")]
    ((start, end),) = _height_spans(flight)
    assert abs(start - 1441 / 240) < 1e-9 and abs(end - 2001 / 240) < 1e-9


def test_the_plot_draws_no_command_once_the_dead_man_timeout_fired(tmp_path):
    """A script ending in silence: the commanded line stayed at 0.5 m/s to the end while the
    vehicle (rightly) braked to a hold; it now breaks where the timeout fired."""
    from quadsim.apps.flight_plot import _steps, export_plot

    path = tmp_path / "silent.mcap"
    record_flight(path, cameras=False, script="z_mode velocity\n1.0 linear.x=0.5\nsilence 2.0\n")
    flight = load_flight(path)
    ts, vs = _steps(flight, lambda tw: tw.linear_x)
    drawn = [t for t, v in zip(ts, vs) if v == 0.5]
    assert max(drawn) == pytest.approx(0.95 + 0.5, abs=0.01)  # the last command, held 0.5 s
    assert math.isnan(vs[-1]) and max(ts) == max(drawn)  # nothing drawn from there to the end (3 s)
    assert export_plot(flight, tmp_path / "silent.png").stat().st_size > 10_000


def test_the_replay_hud_shows_the_z_mode_in_effect():
    """The keyboard session switches to height mode part-way: the HUD follows the switch."""

    flight = load_flight(ROOT / "tests" / "recordings" / "keyboard_session_cascade.mcap")
    (switch_step,) = [step for step, kind, _ in flight.events if kind == "z_mode"]
    switch_ns = switch_step * 1_000_000_000 // flight.physics_hz
    assert flight.z_mode_at(switch_ns - 1_000_000).value == "velocity"
    assert flight.z_mode_at(switch_ns + 1_000_000).value == "height"
    assert flight.z_mode_at(switch_ns).value == "height"  # from the log time of its step on
    assert flight.z_mode_at(switch_ns - 1).value == "velocity"
    with ReplayApp(flight, (640, 360)) as app:
        app.t_ns = switch_ns - 50_000_000
        assert app.model().z_mode == "velocity"
        app.t_ns = switch_ns + 50_000_000
        assert app.model().z_mode == "height"


def test_replay_ros2_without_cyclone_says_so_before_the_summary(monkeypatch, capsys):
    from tests.integration.test_cli_errors import assert_one_line_error, run_cli

    monkeypatch.setitem(sys.modules, "cyclonedds.domain", None)  # as if the ros2 extra were missing
    recording = ROOT / "tests" / "recordings" / "climb_cascade.mcap"
    code, out, err = run_cli(capsys, "replay", str(recording), "--headless", "--ros2")
    assert_one_line_error(code, err, "ros2")
    assert "duration" not in out  # said first, not after the summary


def test_a_recording_started_part_way_plays_from_where_it_starts(tmp_path):
    """A file started with F5 after 3 minutes played from 0 s: 88 % of its timeline showed no
    image, no command and the vehicle at the origin before the flight."""
    from quadsim import Simulator, Twist, record

    out = tmp_path / "part_way.mcap"
    with Simulator(SimConfig(z_mode=ZMode.VELOCITY)) as sim:
        sim.send(Twist(linear_z=1.0))
        sim.step(480)  # 2 s before the recording starts
        with record(sim, out):
            sim.step(480)
    flight = load_flight(out)
    start, end = flight.start_ns, flight.end_ns
    assert start == pytest.approx(2e9, abs=1e7) and end == pytest.approx(4e9, abs=2e7)
    app = ReplayApp(flight, (960, 540), frame_s=0.1)
    assert app.t_ns == start and app.model().state is not None and app.model().state.position_m[2] > 0.5
    app.run(max_frames=5)
    assert app.t_ns == pytest.approx(start + 0.5e9, abs=1e6)
    assert app.model().timeline == pytest.approx((app.t_ns / 1e9, start / 1e9, end / 1e9))
    bar = app.view.layout(app.screen.get_size())["timeline"]
    pygame.event.post(pygame.event.Event(pygame.MOUSEBUTTONDOWN, button=1, pos=(bar.x + bar.width // 4, bar.centery)))
    app.run(max_frames=6)
    assert app.t_ns / 1e9 == pytest.approx((start + 0.25 * (end - start) + 0.1e9) / 1e9, abs=0.05)  # and a frame
    key(pygame.K_HOME)
    app.run(max_frames=7)
    assert app.t_ns == pytest.approx(start + 0.1e9, abs=1e6)  # from the start, and played a frame
    app.close()
