"""SIGINT, SIGTERM and SIGHUP at random moments, from start-up to shutdown, to the process and to its
process group: exit 130 / 143 / 129, no traceback, the summary printed once the run has begun, the
recording finished, no process left behind, no temporary folder left behind.

Each trial is a real `run` with both cameras and two render workers (a process group of
three), paced to real time. Its moment is taken from its own output, not from a clock: a
seeded generator picks a line it prints (or its start) and a short random delay after it. A
trial whose line comes while the vehicle flies ("recording to", the progress lines at a quarter
and at half of the duration) flies 8 s, at least 4 s more after its line, so its signal meets the
flight however late a slow machine ends the delay: every such trial must end by its signal. The
interpreter's own start-up, before quadsim's first statement, is left out: a signal there meets
Python's defaults, not quadsim (test_every_entry_takes_the_signals_first starts at that statement).
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest
from mcap.reader import make_reader

from tests.helpers import ROOT
from tests.helpers import proc as procfs
from tests.helpers.cli import wait_for_line
from tests.helpers.fleets import fleet_toml, vehicle

MOMENTS_PER_CASE = int(os.environ.get("QUADSIM_SIGNAL_MOMENTS", "14"))  # each anchor twice
EXPECTED = {signal.SIGINT: 130, signal.SIGTERM: 143, signal.SIGHUP: 129}  # SIGHUP: the terminal closed


@dataclass
class Trial:
    signum: int
    to_group: bool
    delay_s: float
    anchor: str  # the line of its output the delay ran from ("start": quadsim's first statement)
    returncode: int
    stdout: str
    stderr: str
    recording: Path
    tmpdir: Path
    leftover_processes: bool


def _command(out: Path, duration_s: str = "1.5") -> list[str]:
    return [
        sys.executable,
        str(ROOT / "main.py"),
        "run",
        "--script",
        "square",
        "--duration",
        duration_s,
        "--camera-size",
        "64x48",
        "--realtime",
        "--out",
        str(out),
    ]


#: where a trial's signal goes: (the line it waits for, which of those lines, the delay after it
#: drawn from [low, high) s); None: from quadsim's first statement
ANCHORS = (
    (None, 1, 0.0, 1.0),  # quadsim starting up (from its first statement: see _until_quadsim_takes_signals)
    ("quadsim: starting", 1, 0.0, 0.5),  # the cameras and render workers starting
    ("recording to", 1, 0.0, 0.3),  # flying
    ("sim time:", 1, 0.0, 0.3),  # flying
    ("sim time:", 2, 0.0, 0.3),  # flying
    ("sim time: 100%", 1, 0.0, 0.3),  # closing the recording
    ("final pose", 1, 0.0, 0.3),  # printing the summary, ending
)
#: the anchors after which the vehicle is flying: their trials fly 8 s, so the flight goes on for
#: at least 4 s after each of them (the run prints its progress at every quarter of the duration)
#: and a signal sent late, on a slow machine, still meets it
IN_FLIGHT = {("recording to", 1), ("sim time:", 1), ("sim time:", 2)}


def _flying_command(out: Path) -> list[str]:
    return _command(out, duration_s="8")


def _env(tmpdir: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST")}
    env.update(TMPDIR=str(tmpdir), SDL_VIDEODRIVER="dummy", SDL_AUDIODRIVER="dummy", PYTHONPATH=str(ROOT))
    return env


def _processes_of(tmpdir: Path) -> list[int]:
    """Processes started for one trial (the program and its render workers): they, and only
    they, carry the trial's own TMPDIR in their environment."""
    marker = f"TMPDIR={tmpdir}".encode() + b"\0"
    found = []
    for pid in procfs.pids():
        try:
            if marker in procfs.environ(pid):
                found.append(pid)
        except OSError:
            continue
    return found


def _until_quadsim_takes_signals(proc: subprocess.Popen) -> bool:
    """Wait out Python's own start-up (and the lines of pip's script before quadsim's): until
    quadsim's first statement holds the signals back. False if the process ended first or never
    did so within 60 s. A signal before that meets Python's defaults, not quadsim; how long
    start-up takes depends on the machine's load (0.3 s was seen on a loaded CI machine)."""
    deadline = time.monotonic() + 60.0
    while not procfs.takes_signals(proc.pid):
        if proc.poll() is not None or time.monotonic() > deadline:
            return False
        time.sleep(0.001)  # polling /proc for the state itself: the moment comes from the process
    return True


def _trial(
    folder: Path,
    signum: int,
    to_group: bool,
    delay_s: float,
    command=_command,
    anchor: tuple[str | None, int] = (None, 1),
) -> Trial:
    """A run signalled `delay_s` after the `anchor` line of its output (None: its start)."""
    folder.mkdir(parents=True)
    tmpdir = folder / "tmp"
    tmpdir.mkdir()
    out = folder / "run.mcap"
    proc = subprocess.Popen(
        command(out),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=folder,
        env=_env(tmpdir),
        start_new_session=True,  # a process group of its own, as a shell job has
    )
    stdout, stderr, readers = wait_for_line(proc, *anchor)
    if anchor[0] is None:
        _until_quadsim_takes_signals(proc)
    time.sleep(delay_s)  # the moment: a random delay after the line; no outcome depends on its length
    try:
        if to_group:
            os.killpg(proc.pid, signum)
        else:
            proc.send_signal(signum)
    except ProcessLookupError:
        pass  # it had already finished
    proc.wait(timeout=120)
    for reader in readers:
        reader.join(timeout=30)
    deadline = time.monotonic() + 10.0
    while _processes_of(tmpdir) and time.monotonic() < deadline:
        time.sleep(0.05)
    leftover = bool(_processes_of(tmpdir))
    for pid in _processes_of(tmpdir):
        os.kill(pid, signal.SIGKILL)
    where = "start" if anchor[0] is None else f"{anchor[0]!r} #{anchor[1]}"
    return Trial(
        signum, to_group, delay_s, where, proc.returncode, "".join(stdout), "".join(stderr), out, tmpdir, leftover
    )


@pytest.fixture(scope="module")
def trials(tmp_path_factory) -> list[Trial]:
    base = tmp_path_factory.mktemp("signals")
    rng = random.Random(20261128)
    cases = []
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        for to_group in (False, True):
            # SIGHUP (an ssh session dropped) takes the same path: a few moments of it
            for i in range(MOMENTS_PER_CASE if signum != signal.SIGHUP else 3):
                text, count, low, high = ANCHORS[i % len(ANCHORS)]  # every anchor, in turn
                cases.append((signum, to_group, rng.uniform(low, high), (text, count)))
    with ThreadPoolExecutor(max_workers=2) as pool:
        futures = [
            pool.submit(
                _trial,
                base / f"t{i:03d}",
                signum,
                group,
                delay,
                _flying_command if anchor in IN_FLIGHT else _command,
                anchor,
            )
            for i, (signum, group, delay, anchor) in enumerate(cases)
        ]
        results = [f.result() for f in futures]
    stopped = sum(t.returncode != 0 for t in results)
    print(f"\nsignals: {len(results)} trials, {stopped} stopped by the signal")
    return results


def _where(t: Trial) -> str:
    target = "group" if t.to_group else "process"
    return f"{signal.Signals(t.signum).name} to the {target} {t.delay_s:.2f} s after {t.anchor}"


def test_no_traceback_and_the_right_exit_code(trials):
    for t in trials:
        assert "Traceback" not in t.stderr and "Error" not in t.stderr.replace("quadsim: error", ""), (
            f"{_where(t)}:\n{t.stderr}"
        )
        assert t.returncode in (0, EXPECTED[t.signum]), f"{_where(t)}: exit {t.returncode}\n{t.stderr}"
    # every signal sent while the vehicle flew stopped the run, whatever the machine's load
    flying = [t for t in trials if any(t.anchor == f"{a!r} #{n}" for a, n in IN_FLIGHT)]
    assert len(flying) >= len(trials) // 3
    for t in flying:
        assert t.returncode == EXPECTED[t.signum], f"{_where(t)}: exit {t.returncode}\n{t.stdout}\n{t.stderr}"


def test_no_process_and_no_temporary_folder_left_behind(trials):
    for t in trials:
        assert not t.leftover_processes, f"{_where(t)}: its render workers outlived it"
        assert not list(t.tmpdir.iterdir()), f"{_where(t)}: left {list(t.tmpdir.iterdir())}"


def test_the_summary_is_printed_and_the_recording_finished(trials):
    for t in trials:
        if "recording to" not in t.stdout:
            continue  # stopped before the run began: nothing to summarise
        assert "final pose" in t.stdout and "recording " in t.stdout, f"{_where(t)}:\n{t.stdout}\n{t.stderr}"
        if t.returncode:  # stopped during the run, or once it had finished
            assert "the recording is finished and readable" in t.stderr or "nothing was cut short" in t.stderr, (
                f"{_where(t)}:\n{t.stderr}"
            )
        with open(t.recording, "rb") as fh:
            summary = make_reader(fh).get_summary()  # a finished file has its summary
        assert summary is not None and summary.statistics is not None, _where(t)
        assert summary.statistics.message_count > 0


# --- a fleet --------------------------------------------------------------------------------------

FLEET = fleet_toml(
    vehicle("alpha", (0.0, 0.0, 0.0, 0.0), input="script:square", cameras=["front", "floor"]),
    vehicle("bravo", (0.0, 3.0, 0.0, 0.0), input="script:yaw"),
)


def test_a_fleet_run_stopped_at_any_moment_ends_cleanly_with_every_vehicle_recorded(tmp_path):
    """`run --fleet` (one vehicle with cameras and two render workers holding the fleet), signalled
    at seeded random moments, to the process and to its group: 130 / 143, no traceback, no
    process left, and a finished recording with both vehicles' states, as many of each (one clock)."""
    from quadsim.recording.flight import load_flights

    (tmp_path / "pair.toml").write_text(FLEET)

    def command(out: Path) -> list[str]:
        fleet = ["run", "--fleet", str(tmp_path / "pair.toml"), "--duration", "1.5", "--camera-size", "64x48"]
        return [sys.executable, str(ROOT / "main.py"), *fleet, "--out", str(out)]

    t0 = time.monotonic()
    calm = subprocess.run(command(tmp_path / "calm.mcap"), capture_output=True, text=True, env=_env(tmp_path))
    wall_s = time.monotonic() - t0
    assert calm.returncode == 0, calm.stderr
    rng = random.Random(20261125)
    cases = [
        (signum, to_group, rng.uniform(0.12, wall_s * 1.6))
        for signum in (signal.SIGINT, signal.SIGTERM)
        for to_group in (False, True)
        for _ in range(3)
    ]
    with ThreadPoolExecutor(max_workers=2) as pool:
        trials = list(pool.map(lambda c: _trial(tmp_path / f"t{c[0]:02d}", *c[1], command=command), enumerate(cases)))
    for t in trials:
        assert "Traceback" not in t.stderr and t.returncode in (0, EXPECTED[t.signum]), f"{_where(t)}:\n{t.stderr}"
        assert not t.leftover_processes and not list(t.tmpdir.iterdir()), _where(t)
        if "recording to" not in t.stdout:
            continue
        with open(t.recording, "rb") as fh:
            assert make_reader(fh).get_summary() is not None, _where(t)  # finished
        flights = load_flights(t.recording)
        states = {name: len(f.states) for name, f in flights.items()}
        assert list(states) == ["alpha", "bravo"] and states["alpha"] == states["bravo"], (_where(t), states)
        assert not any(f.damage for f in flights.values()), _where(t)
    assert sum(t.returncode != 0 for t in trials) >= len(trials) // 4  # as in test_no_traceback_and_the_right_exit_code


# --- the first second --------------------------------------------------------------------------

FIRST_SECOND_TRIALS = 40
#: the moments: up to this long after quadsim's first statement, while it imports pybullet, pygame
#: and the rest (about 0.3 s on an idle machine, longer on a busy one) and as the run begins; the
#: run, paced to real time, lasts seconds more, so every signal meets it
FIRST_SECOND_S = 0.8


def test_a_signal_in_the_first_second(tmp_path):
    """The signal at a random moment of quadsim's first 0.8 s: every signal ends it with 130 / 143,
    a line saying why and no traceback, during the imports of pybullet, pygame and the rest as well.
    (Its moments count from quadsim's first statement, read from /proc, so the share that lands in
    the imports does not hang on the machine's load; CPU hogs beside it are not needed for that.)"""
    rng = random.Random(20261125)
    cases = [
        (signal.SIGINT if i % 2 else signal.SIGTERM, rng.uniform(0.0, FIRST_SECOND_S))
        for i in range(FIRST_SECOND_TRIALS)
    ]
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(
            pool.map(
                lambda c: (c, _signalled_after_first_act(tmp_path / f"t{c[0]:03d}", MAIN_PY, *c[1], PACED_RUN)),
                enumerate(cases),
            )
        )
    for (_, (signum, delay)), (code, stderr) in results:
        where = f"{signal.Signals(signum).name} {delay:.2f} s after quadsim took the signals"
        assert code == EXPECTED[signum], f"{where}: exit {code}\n{stderr}"
        assert "Traceback" not in stderr, f"{where}:\n{stderr}"
        said = "interrupted" if signum == signal.SIGINT else "terminated"
        assert said in stderr, f"{where}:\n{stderr}"  # said why it stopped, whatever stage it was at


# --- the three ways of starting, from quadsim's first statement on -------------------------------


def _pip_script(folder: Path) -> Path:
    """The `quadsim` command as pip writes it for [project.scripts] (its template, word for word:
    `import re` and `import sys` come first, then the entry point's module is imported)."""
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    target = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]["quadsim"]
    module, function = target.split(":")
    script = folder / "quadsim"
    script.write_text(
        f"#!{sys.executable}\n"
        "# -*- coding: utf-8 -*-\n"
        "import re\n"
        "import sys\n"
        f"from {module} import {function}\n"
        "if __name__ == '__main__':\n"
        "    sys.argv[0] = re.sub(r'(-script\\.pyw|\\.exe)?$', '', sys.argv[0])\n"
        f"    sys.exit({function}())\n"
    )
    script.chmod(0o755)
    return script


MAIN_PY = [sys.executable, str(ROOT / "main.py")]
ENTRIES = {
    "quadsim": lambda folder: [str(_pip_script(folder))],
    "python -m quadsim": lambda folder: [sys.executable, "-m", "quadsim"],
    "python main.py": lambda folder: MAIN_PY,
}
# after quadsim's first act on the signals: while they are held back (0), while quadsim.apps.launch
# imports the rest, as SignalStop goes in, during the heavy imports, once the run has begun
MOMENTS_AFTER_FIRST_ACT = [
    (signal.SIGINT, 0.0),
    (signal.SIGTERM, 0.002),
    (signal.SIGINT, 0.01),
    (signal.SIGTERM, 0.05),
    (signal.SIGINT, 0.3),
]


#: the run every trial of this file's start-up tests starts; PACED_RUN lasts 5 s of wall time
#: more, so that a signal up to FIRST_SECOND_S after its first statement always meets it
QUICK_RUN = ["run", "--script", "square", "--cameras", "none", "--out", "run.mcap"]
PACED_RUN = [*QUICK_RUN, "--duration", "5", "--realtime"]


def _signalled_after_first_act(
    folder: Path, starts: list[str], signum: int, delay_s: float, run: list[str] = QUICK_RUN
) -> tuple[int, str]:
    """`starts` + `run` signalled `delay_s` after quadsim's first statement; (exit code, stderr)."""
    folder.mkdir(parents=True)
    command = [*starts, *run]
    proc = subprocess.Popen(
        command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, cwd=folder, env=_env(folder)
    )
    assert _until_quadsim_takes_signals(proc), f"{starts}: quadsim never took the signals"
    time.sleep(delay_s)  # the moment (drawn at random)
    proc.send_signal(signum)
    _, stderr = proc.communicate(timeout=120)
    return proc.returncode, stderr


@pytest.mark.parametrize("entry", list(ENTRIES))
def test_every_entry_takes_the_signals_first(entry, tmp_path):
    """The `quadsim` command (the script pip writes: it imports the package `quadsim` first),
    `python -m quadsim` and main.py: a signal at any moment from quadsim's first statement on,
    even before quadsim's handlers exist, ends the program with 130 / 143 and a line, no traceback."""
    # the command is made (pip's script written) before the threads start: a script written while
    # another thread forks is held open for writing in that child until its exec, and starting it
    # then fails with "Text file busy" (ETXTBSY)
    starts = ENTRIES[entry](tmp_path)
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(
            pool.map(
                lambda c: (c[1], _signalled_after_first_act(tmp_path / f"t{c[0]}", starts, *c[1])),
                enumerate(MOMENTS_AFTER_FIRST_ACT),
            )
        )
    for (signum, delay), (code, stderr) in results:
        where = f"{entry}: {signal.Signals(signum).name} {delay * 1000:.0f} ms after quadsim took the signals"
        assert "Traceback" not in stderr and code == EXPECTED[signum], f"{where}: exit {code}\n{stderr}"
        said = "interrupted" if signum == signal.SIGINT else "terminated"
        assert said in stderr, f"{where}:\n{stderr}"


# run by each entry's interpreter: what it has imported (beyond Python's start-up and the lines of
# pip's script before its import of quadsim) when quadsim first acts on SIGINT / SIGTERM
FIRST_ACT_PROBE = """
import json, os, sys, _signal
ENTRY, MAIN_PY, SCRIPT = sys.argv[1:4]
del sys.argv[1:4]
if ENTRY == "quadsim":
    import re  # the script's own first lines
elif ENTRY == "python -m quadsim":
    import runpy  # Python's, for -m
before = set(sys.modules)

def first_act(real, acts):
    def wrapper(*args):
        if acts(*args):
            print(json.dumps(sorted(set(sys.modules) - before)), flush=True)
            os._exit(0)
        return real(*args)
    return wrapper

_signal.pthread_sigmask = first_act(_signal.pthread_sigmask, lambda how, mask: how == _signal.SIG_BLOCK)
_signal.signal = first_act(_signal.signal, lambda signum, handler: signum in (_signal.SIGINT, _signal.SIGTERM))
if ENTRY == "quadsim":
    exec(compile(open(SCRIPT).read(), SCRIPT, "exec"), {"__name__": "__main__"})
elif ENTRY == "python -m quadsim":
    runpy._run_module_as_main("quadsim")
else:
    sys.path[0] = os.path.dirname(MAIN_PY)
    exec(compile(open(MAIN_PY).read(), MAIN_PY, "exec"), {"__name__": "__main__", "__file__": MAIN_PY})
print("null")
"""
FIRST_ACT_AFTER = {  # what each entry imports before quadsim's first act: nothing but the way to it
    "quadsim": ["quadsim", "quadsim.apps", "quadsim.apps.launch"],
    "python -m quadsim": ["quadsim", "quadsim.apps", "quadsim.apps.launch"],
    "python main.py": [],
}


@pytest.mark.parametrize("entry", list(ENTRIES))
def test_quadsim_takes_the_signals_before_it_imports_anything_else(entry, tmp_path):
    """The window in which a signal still meets Python's default handler (a traceback) ends with
    quadsim's first statement: nothing is imported before it (typing in quadsim/__init__.py took
    10 ms, signal's enum in main.py a few) but the package on the way to quadsim.apps.launch."""
    done = subprocess.run(
        [sys.executable, "-c", FIRST_ACT_PROBE, entry, str(ROOT / "main.py"), str(_pip_script(tmp_path)), "--version"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=_env(tmp_path),
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.splitlines()[-1]) == FIRST_ACT_AFTER[entry], done.stdout


def test_a_signal_once_the_command_has_finished_says_nothing_was_cut_short(capsys, monkeypatch):
    """Ctrl-C after the last line (the recording already closed): exit 130, and a line that says so."""
    import quadsim.apps.cli as cli
    from quadsim.apps.commands import scenarios

    def finished_then_interrupted(args):
        print("done")
        os.kill(os.getpid(), signal.SIGINT)
        return 0

    monkeypatch.setattr(scenarios, "main", finished_then_interrupted)
    assert cli.main(["scenarios"]) == 130
    out, err = capsys.readouterr()
    assert out.startswith("done")
    assert err.strip().endswith("quadsim: interrupted once the command had finished: nothing was cut short")


def test_a_window_that_recorded_nothing_says_no_recording_was_finished(capsys):
    """`fly --no-record` stopped by Ctrl-C said 'the recording is finished and readable'."""
    from quadsim.apps.commands.fly import _report
    from quadsim.session.stopping import SignalStop

    for recordings, said in (([], "interrupted"), ([Path("f.mcap")], "interrupted; the recording is finished")):
        with SignalStop() as stop:
            stop.signum = signal.SIGINT  # what its handler sets on Ctrl-C
            assert _report(5.1, recordings, None) == 130
        err = capsys.readouterr().err.strip()
        assert err.startswith(said) and ("recording" in err) == bool(recordings), err
