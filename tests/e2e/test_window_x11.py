"""The window on a real X server (Xvfb): destroyed from outside, or its X connection lost, `fly`
still finishes its recording and exits cleanly (issue 9, "lost display").

Each case is a real `python main.py fly` with the keyboard, in its own Xvfb, with SDL's x11
driver, and a real X client doing the damage once the window is mapped and the recording open:
- the X server is killed (as at the end of a session);
- `xdotool windowkill` / `xkill -id`: the server closes the program's connection;
- `xdotool windowclose`: another client destroys the window (BadWindow / BadDrawable follow);
- WM_DELETE_WINDOW, what a window manager's close button sends: the normal end, exit 0.
Before the fix Xlib printed `XIO: fatal IO error` or `BadWindow` and called exit(1) inside an
SDL call: no summary in the file (it needed `recover`), no message from quadsim.

Skipped when Xvfb or xdotool is missing (CI installs them: .ci/run).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import itertools
import os
import select
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from mcap.reader import make_reader

from quadsim.apps.window.x11_guard import EXIT_DISPLAY_LOST, LEGACY_ENV
from quadsim.errors import QuadsimError
from quadsim.recording.mcap_scan import McapFile
from tests.helpers import ROOT, default_core

LOST = "the window's display was lost ("
START_UP_NOTES = ("quadsim: starting ", "quadsim: compiling ")
EXIT_TIMEOUT_S = 30.0

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(shutil.which("Xvfb") is None, reason="Xvfb is not installed (apt-get install xvfb)"),
    pytest.mark.skipif(shutil.which("xdotool") is None, reason="xdotool is not installed (apt-get install xdotool)"),
]


@dataclass
class XServer:
    display: str
    proc: subprocess.Popen[bytes]

    def env(self) -> dict[str, str]:
        return {"DISPLAY": self.display}


#: display numbers for this worker's X servers, each used once in a run (Xvfb's own choice is the
#: lowest free one, which servers that other workers' tests terminate keep freeing): once, with
#: Xvfb's choice, a replay window never appeared on its server (display :0, the program playing
#: frames all the while); numbers used once leave no client a way to a server that had its number
_DISPLAYS = itertools.count(100 + 200 * int(os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw") or 0))


def _start_xvfb() -> tuple[subprocess.Popen[bytes], str]:
    """An Xvfb on the next display number of this worker's that is free, and that number; it has
    said it is ready (-displayfd)."""
    for _ in range(50):
        number = next(_DISPLAYS)
        read_fd, write_fd = os.pipe()
        proc = subprocess.Popen(
            ["Xvfb", f":{number}", "-displayfd", str(write_fd), "-screen", "0", "1280x800x24", "-nolisten", "tcp"],
            pass_fds=(write_fd,),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        os.close(write_fd)
        said = b""
        try:
            deadline = time.monotonic() + 20
            while not said.endswith(b"\n"):
                ready, _, _ = select.select([read_fd], [], [], max(0.0, deadline - time.monotonic()))
                chunk = os.read(read_fd, 16) if ready else b""
                if not chunk:
                    break  # it ended (the number is taken) or never said it was ready
                said += chunk
        finally:
            os.close(read_fd)
        if said.endswith(b"\n"):
            return proc, f":{int(said)}"
        proc.kill()
        proc.wait()
    pytest.fail("Xvfb did not start on any of 50 display numbers")


@pytest.fixture
def xserver() -> Iterator[XServer]:
    """An Xvfb of its own, on a display number no other server of the run has had."""
    proc, display = _start_xvfb()
    try:
        yield XServer(display, proc)
    finally:
        if proc.poll() is None:
            proc.terminate()  # lets it remove its socket and lock file
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
        proc.wait()


@dataclass
class Flight:
    proc: subprocess.Popen[bytes]
    out: Path
    tmpdir: Path
    logs: Path  # its stdout and stderr go to files there: a pipe nobody reads could block it
    window: int = 0

    def output(self, timeout_s: float) -> tuple[str, str]:
        """Waits for the program to end (TimeoutExpired after timeout_s); its stdout and stderr."""
        self.proc.wait(timeout=timeout_s)
        return (self.logs / "stdout").read_text(errors="replace"), (self.logs / "stderr").read_text(errors="replace")

    def killed_output(self) -> tuple[str, str]:
        _kill(self)
        return self.output(30)


def _env(xserver: XServer, tmpdir: Path, legacy: bool = False) -> dict[str, str]:
    env = {  # the flight core as a user's window has it by default: compiled
        k: v
        for k, v in default_core(os.environ).items()
        if not k.startswith("PYTEST") and k not in ("SDL_VIDEODRIVER", LEGACY_ENV)
    }
    env.update(xserver.env(), TMPDIR=str(tmpdir), SDL_AUDIODRIVER="dummy", PYTHONPATH=str(ROOT))
    env["PYTHONFAULTHANDLER"] = "1"
    if legacy:
        env[LEGACY_ENV] = "1"
    return env


def _xdotool(xserver: XServer, *args: str) -> str:
    done = subprocess.run(
        ["xdotool", *args], env={**os.environ, **xserver.env()}, capture_output=True, text=True, timeout=10
    )
    return done.stdout


def _start(xserver: XServer, tmp_path: Path, command: list[str], legacy: bool = False) -> Flight:
    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    out = tmp_path / "flight.mcap"
    logs = tmp_path / "logs"
    logs.mkdir()
    with (logs / "stdout").open("wb") as stdout, (logs / "stderr").open("wb") as stderr:
        proc = subprocess.Popen(
            [sys.executable, str(ROOT / "main.py"), *command],
            cwd=ROOT,
            env=_env(xserver, tmpdir, legacy),
            stdout=stdout,
            stderr=stderr,
            start_new_session=True,
        )
    return Flight(proc, out, tmpdir, logs)


def _fly(xserver: XServer, tmp_path: Path, *extra: str, legacy: bool = False) -> Flight:
    """`fly` with the keyboard, up and flying: its window mapped, its recording open."""
    out = tmp_path / "flight.mcap"
    flight = _start(xserver, tmp_path, ["fly", "--input", "keyboard", "--out", str(out), *extra], legacy)
    _wait_for_window(xserver, flight, lambda: out.exists())
    _wait_until(flight, lambda: _intact_messages(out) > 100, "a hundred messages in its recording")
    return flight


def _intact_messages(path: Path) -> int:
    """How many messages the recording being written holds in whole chunks so far (0 before its
    magic bytes are all written)."""
    try:
        with McapFile(path) as growing:
            return growing.message_count
    except QuadsimError:
        return 0


def _wait_until(flight: Flight, done: Callable[[], bool], what: str) -> None:
    deadline = time.monotonic() + 90  # generous: a bound on a hang, not a moment
    while not done():
        if flight.proc.poll() is not None or time.monotonic() > deadline:
            out, err = flight.killed_output() if flight.proc.poll() is None else flight.output(10)
            pytest.fail(f"the flight never had {what}:\n{out}\n{err}")
        time.sleep(0.1)  # polling: nothing is judged by how long it took


def _wait_for_title(xserver: XServer, flight: Flight, title: str) -> None:
    """Until the window bears quadsim's title: it is set right after the X11 guard is installed
    (before it, SDL's "pygame window"), so a kill from then on meets the guard."""
    window = str(flight.window)
    _wait_until(flight, lambda: _xdotool(xserver, "getwindowname", window).startswith(title), f"the title {title!r}")


def _wait_for_window(xserver: XServer, flight: Flight, ready: Callable[[], bool] | None = None) -> None:
    # by pid: this xdotool's `search --name` does not match SDL's UTF8_STRING window names
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline:
        if flight.proc.poll() is not None:
            out, err = flight.output(10)
            pytest.fail(f"the program ended before its window was up ({flight.proc.returncode}):\n{out}\n{err}")
        found = _xdotool(xserver, "search", "--onlyvisible", "--pid", str(flight.proc.pid)).split()
        if found and (ready is None or ready()):
            flight.window = int(found[0])
            return
        time.sleep(0.2)
    windows = _xdotool(xserver, "search", "--pid", str(flight.proc.pid)).split()
    flight.proc.send_signal(signal.SIGABRT)  # faulthandler prints where every thread is
    try:
        out, err = flight.output(10)
    except subprocess.TimeoutExpired:
        out, err = flight.killed_output()
    _kill(flight)
    pytest.fail(
        f"the window did not appear (windows of the process, mapped or not: {windows}; "
        f"recording there: {flight.out.exists()}):\n{out}\n{err}"
    )


def _kill(flight: Flight) -> None:
    try:
        os.killpg(flight.proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def _finish(flight: Flight) -> tuple[int, str, str]:
    """Wait for the program to end by itself (within EXIT_TIMEOUT_S, or the test fails);
    (exit code, stdout, stderr)."""
    try:
        out, err = flight.output(EXIT_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        out, err = flight.killed_output()
        pytest.fail(f"still running {EXIT_TIMEOUT_S:.0f} s after the display went away:\n{out}\n{err}")
    return flight.proc.returncode, out, err


def _assert_display_lost_exit(code: int, out: str, err: str) -> None:
    """EXIT_DISPLAY_LOST; any other end is shown in full (a crash's stack, as faulthandler prints
    it, is many lines long, and pytest shortens an assertion's message)."""
    if code != EXIT_DISPLAY_LOST:
        pytest.fail(f"exit code {code}, not {EXIT_DISPLAY_LOST}\n--- stdout\n{out}\n--- stderr\n{err}")


def _leftovers(flight: Flight) -> list[str]:
    """Processes of this trial still alive (they carry its TMPDIR) and temporary folders left."""
    marker = f"TMPDIR={flight.tmpdir}".encode() + b"\0"
    alive = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if marker in (entry / "environ").read_bytes():
                    alive.append(f"process {entry.name}")
            except OSError:
                continue
    return alive + [f"folder {p.name}" for p in flight.tmpdir.iterdir()]


def _assert_finished_recording(path: Path, messages: int = 100) -> None:
    """A recording with its summary and more than `messages` messages, that `info` reads."""
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None, "the recording has no summary (it would need `recover`)"
    assert summary.statistics is not None and summary.statistics.message_count > messages
    info = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "info", str(path)], capture_output=True, text=True, timeout=60
    )
    assert info.returncode == 0, info.stdout + info.stderr


def _said(err: str) -> list[str]:
    """stderr's lines but the start-up notes (what is being started: cameras, the flight core)."""
    return [line for line in err.strip().splitlines() if not line.startswith(START_UP_NOTES)]


def _assert_lost_cleanly(flight: Flight, expected_reason: str) -> None:
    code, out, err = _finish(flight)
    assert "Traceback" not in out + err, err
    _assert_display_lost_exit(code, out, err)
    lines = _said(err)
    assert len(lines) == 1, err  # quadsim's line, and no "XIO: fatal IO error" / "X Error of failed request"
    assert lines[0].startswith(LOST) and expected_reason in lines[0], lines[0]
    assert lines[0].endswith("; the recording is finished"), lines[0]
    assert "flew " in out and f"recording       {flight.out}" in out, out
    _assert_finished_recording(flight.out)
    assert not _leftovers(flight)


# --- the X server goes away ------------------------------------------------------------------


@pytest.mark.parametrize("cameras", [["--cameras", "none"], ["--camera-size", "64x48"]], ids=["no-cameras", "cameras"])
def test_x_server_killed(xserver, tmp_path, cameras):
    flight = _fly(xserver, tmp_path, *cameras)
    xserver.proc.terminate()
    _assert_lost_cleanly(flight, f"the connection to the X server {xserver.display} was closed")


# --- another client kills the program's connection --------------------------------------------


@pytest.mark.parametrize("cameras", [["--cameras", "none"], ["--camera-size", "64x48"]], ids=["no-cameras", "cameras"])
def test_window_killed(xserver, tmp_path, cameras):
    flight = _fly(xserver, tmp_path, *cameras)
    _xdotool(xserver, "windowkill", str(flight.window))
    _assert_lost_cleanly(flight, f"the connection to the X server {xserver.display} was closed")


@pytest.mark.parametrize("cameras", [["--cameras", "none"], ["--camera-size", "64x48"]], ids=["no-cameras", "cameras"])
def test_window_killed_while_starting(xserver, tmp_path, cameras):
    """Killed as soon as it is mapped, while it still says "quadsim is starting" (loading the
    world, starting the cameras): the same clean end as in flight. The guard used to be installed
    after the start-up, and Xlib printed "X connection to :N broken" and exited 1 there."""
    out = tmp_path / "flight.mcap"
    flight = _start(xserver, tmp_path, ["fly", "--input", "keyboard", "--out", str(out), *cameras])
    _wait_for_window(xserver, flight)  # mapped: start-up is under way, or only just over
    _wait_for_title(xserver, flight, "quadsim")
    _xdotool(xserver, "windowkill", str(flight.window))
    code, stdout, err = _finish(flight)
    assert "Traceback" not in stdout + err, err
    _assert_display_lost_exit(code, stdout, err)
    assert _said(err) == [
        f"{LOST}the connection to the X server {xserver.display} was closed); the recording is finished"
    ]
    assert f"recording       {out}" in stdout, stdout
    _assert_finished_recording(out, messages=0)
    assert not _leftovers(flight)


@pytest.mark.skipif(shutil.which("xkill") is None, reason="xkill is not installed (apt-get install x11-utils)")
def test_xkill(xserver, tmp_path):
    flight = _fly(xserver, tmp_path, "--cameras", "none")
    subprocess.run(["xkill", "-id", str(flight.window)], env={**os.environ, **xserver.env()}, capture_output=True)
    _assert_lost_cleanly(flight, "was closed")


# --- another client destroys the window -------------------------------------------------------


def test_window_destroyed_from_outside(xserver, tmp_path):
    flight = _fly(xserver, tmp_path, "--cameras", "none")
    _xdotool(xserver, "windowclose", str(flight.window))  # XDestroyWindow, from another client
    _assert_lost_cleanly(flight, "the window was destroyed by another program: Bad")


# --- a libX11 without XSetIOErrorExitHandler (older than 1.7): the best effort ----------------


def test_x_server_killed_old_libx11(xserver, tmp_path):
    """Xlib will call exit(): the recording is finished from inside its IO error handler, the
    same lines said, and the process ends with the same code."""
    flight = _fly(xserver, tmp_path, "--camera-size", "64x48", legacy=True)
    xserver.proc.terminate()
    code, out, err = _finish(flight)
    assert "Traceback" not in out + err, err
    _assert_display_lost_exit(code, out, err)
    assert _said(err) == [
        f"{LOST}the connection to the X server {xserver.display} was closed); the recording is finished"
    ]
    assert "flew " in out and f"recording       {flight.out}" in out, out
    _assert_finished_recording(flight.out)
    assert not _leftovers(flight)


# --- the normal end is unchanged --------------------------------------------------------------


class _ClientMessage(ctypes.Structure):
    _fields_ = [
        ("type", ctypes.c_int),
        ("serial", ctypes.c_ulong),
        ("send_event", ctypes.c_int),
        ("display", ctypes.c_void_p),
        ("window", ctypes.c_ulong),
        ("message_type", ctypes.c_ulong),
        ("format", ctypes.c_int),
        ("data", ctypes.c_long * 5),
    ]


class _XEvent(ctypes.Union):
    _fields_ = [("xclient", _ClientMessage), ("pad", ctypes.c_long * 24)]


def _send_wm_delete(display_name: str, window: int) -> None:
    """What a window manager's close button does: a WM_PROTOCOLS / WM_DELETE_WINDOW message."""
    x11 = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
    x11.XOpenDisplay.restype = ctypes.c_void_p
    x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
    x11.XInternAtom.restype = ctypes.c_ulong
    x11.XInternAtom.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int]
    x11.XSendEvent.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_long, ctypes.POINTER(_XEvent)]
    x11.XFlush.argtypes = [ctypes.c_void_p]
    x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    dpy = x11.XOpenDisplay(display_name.encode())
    assert dpy, f"cannot open {display_name}"
    try:
        event = _XEvent()
        event.xclient.type = 33  # ClientMessage
        event.xclient.window = window
        event.xclient.message_type = x11.XInternAtom(dpy, b"WM_PROTOCOLS", 0)
        event.xclient.format = 32
        event.xclient.data[0] = x11.XInternAtom(dpy, b"WM_DELETE_WINDOW", 0)
        x11.XSendEvent(dpy, window, 0, 0, ctypes.byref(event))
        x11.XFlush(dpy)
    finally:
        x11.XCloseDisplay(dpy)


def test_window_closed_normally(xserver, tmp_path):
    flight = _fly(xserver, tmp_path, "--camera-size", "64x48")
    _send_wm_delete(xserver.display, flight.window)
    code, out, err = _finish(flight)
    assert code == 0, (code, out, err)
    assert "Traceback" not in out + err and LOST not in err, err
    assert "flew " in out, out
    _assert_finished_recording(flight.out)
    assert not _leftovers(flight)


# --- the replay window ------------------------------------------------------------------------


def test_replay_window_killed(xserver, tmp_path):
    recording = ROOT / "tests" / "recordings" / "climb_cascade.mcap"
    flight = _start(xserver, tmp_path, ["replay", str(recording), "--loop"])
    _wait_for_window(xserver, flight)
    _wait_for_title(xserver, flight, "quadsim replay")  # guarded: the replay is playing
    _xdotool(xserver, "windowkill", str(flight.window))
    code, out, err = _finish(flight)
    assert "Traceback" not in out + err, err
    _assert_display_lost_exit(code, out, err)
    assert _said(err) == [f"{LOST}the connection to the X server {xserver.display} was closed)"]


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["sigint", "sigterm"])
def test_a_signal_ends_the_replay_window_at_its_next_frame(xserver, tmp_path, signum):
    """`kill` or Ctrl-C to a playing replay window: it ends within seconds with 130 / 143 and
    one line (it used to go on playing, ignoring the first signal)."""
    recording = ROOT / "tests" / "recordings" / "climb_cascade.mcap"
    flight = _start(xserver, tmp_path, ["replay", str(recording), "--loop"])
    _wait_for_window(xserver, flight)
    _wait_for_title(xserver, flight, "quadsim replay")  # guarded: the replay is playing
    flight.proc.send_signal(signum)
    code, out, err = _finish(flight)
    assert code == 128 + signum, (code, out, err)
    assert "Traceback" not in out + err, err
    name = "interrupted" if signum == signal.SIGINT else "terminated"
    assert err.strip().splitlines()[-1] == name, err
    assert not _leftovers(flight)
