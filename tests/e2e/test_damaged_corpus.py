"""Every read command over a few hundred damaged, crafted and foreign recordings: no traceback,
the documented exit code, no hang, bounded memory; `recover` keeps every intact chunk and never
returns a garbled topic name. The commands run in-process (through the CLI's `main`) for speed;
a sample runs as real processes to check exit codes and stderr as a user sees them."""

from __future__ import annotations

import contextlib
import io
import multiprocessing
import resource
import signal
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
from mcap.reader import make_reader

from quadsim.apps.cli import main
from quadsim.recording.mcap_scan import McapFile
from tests.helpers import ROOT
from tests.helpers.damaged_corpus import Damaged, make_corpus
from tests.helpers.recording import record_flight

CAMERA_SCRIPT = "z_mode height\n1.0 linear.z=0\n1.0 linear.x=1.0 angular.z=0.5\n"
PLAIN_SCRIPT = "z_mode height\n1.0 linear.z=0\n0.5 linear.x=1.0 angular.z=0.5\n0.5 linear.y=-0.5\n"
TIME_LIMIT_S = 60.0  # per run: generous, a hang is minutes
MEMORY_LIMIT_BYTES = 300 * 1024 * 1024  # growth of the process's peak memory (max RSS) in one run


class Hang(BaseException):
    """Raised by the alarm in a run that takes longer than TIME_LIMIT_S."""


@dataclass(frozen=True)
class Command:
    name: str
    argv: Callable[[Path, Path], list[str]]
    exit_codes: frozenset[int]
    error_line: bool = True  # a non-zero exit ends with a one-line "quadsim: error:" on stderr
    # run on every n-th file of each family (and source) only, its first included: the slow
    # commands (videos, plots, the window) meet every kind of damage, on fewer files of each
    every: int = 1


COMMANDS = [
    Command("info", lambda f, tmp: ["info", str(f)], frozenset({0, 2})),
    # the headless summary of every file; the videos (a file without cameras ends in exit 2 there)
    # and the plot of one file in twelve of each family (its first always): each costs more than
    # half a second a file, in drawing and encoding, not in reading (they read as the summary does)
    Command("replay", lambda f, tmp: ["replay", "--headless", str(f)], frozenset({0, 2})),
    Command("mp4", lambda f, tmp: ["replay", "--mp4", str(tmp / "mp4"), str(f)], frozenset({0, 2}), every=12),
    Command("plot", lambda f, tmp: ["replay", "--plot", str(tmp / "p.png"), str(f)], frozenset({0, 2}), every=12),
    # the two that fly the file again (the same reading first): every other file of each family
    Command("resim", lambda f, tmp: ["replay", "--resim", "--no-record", str(f)], frozenset({0, 2}), every=2),
    Command("check", lambda f, tmp: ["check", str(f)], frozenset({0, 1, 2}), error_line=False, every=2),
    Command("recover", lambda f, tmp: ["recover", str(f), "-o", str(tmp / "recovered.mcap")], frozenset({0, 2})),
    # the playback window (SDL's dummy video driver), three frames of every sixth file
    Command("window", lambda f, tmp: ["replay", "--window", "320x240", str(f)], frozenset({0, 2}), every=6),
]


@contextlib.contextmanager
def _window_for_three_frames():
    """`replay` opens its window as if a display were there, and plays three frames."""
    from quadsim.apps.commands import replay
    from quadsim.apps.window.replay import ReplayApp

    run = ReplayApp.run
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(replay, "has_display", lambda: True)
        mp.setattr(
            ReplayApp, "run", lambda self, max_frames=None, before_frame=None, stop=None: run(self, 3, stop=stop)
        )
        yield


@dataclass
class Run:
    command: str
    file: Damaged
    code: int | None
    out: str
    err: str
    exception: str | None  # an exception that escaped main: a traceback for the user
    seconds: float
    rss_growth_bytes: int
    problems: list[str]


def _max_rss_bytes() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # kB on Linux


def _on_alarm(signum, frame):
    raise Hang()


def run_in_process(argv: list[str]) -> tuple[int | None, str, str, str | None, float, int]:
    out, err = io.StringIO(), io.StringIO()
    code: int | None = None
    exception = None
    rss_before = _max_rss_bytes()
    previous = signal.signal(signal.SIGALRM, _on_alarm)
    signal.setitimer(signal.ITIMER_REAL, TIME_LIMIT_S)
    t0 = time.perf_counter()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(argv)
    except SystemExit as exc:  # argparse
        code = exc.code if isinstance(exc.code, int) else 2
    except Hang:
        exception = "Hang"
    except BaseException as exc:  # whatever escapes is what a user would see as a traceback
        exception = f"{type(exc).__name__}: {str(exc)[:120]}"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    seconds = time.perf_counter() - t0
    return code, out.getvalue(), err.getvalue(), exception, seconds, _max_rss_bytes() - rss_before


def _judge(cmd: Command, run: Run) -> None:
    p = run.problems
    if run.exception == "Hang":
        p.append("hang")
    elif run.exception is not None:
        p.append("traceback")
    if "Traceback" in run.out or "Traceback" in run.err:
        p.append("traceback")
    if run.exception is None and run.code not in cmd.exit_codes:
        p.append(f"exit {run.code}")
    if cmd.error_line and run.code not in (0, None):
        lines = [line for line in run.err.splitlines() if line.strip()]
        if not lines or not lines[-1].startswith("quadsim: error: "):
            p.append("no error line")
    if run.seconds > TIME_LIMIT_S and "hang" not in p:
        p.append("hang")
    if run.file.sound and run.code != 0 and (run.file.cameras or cmd.name != "mp4"):
        p.append("sound file refused")
    if run.rss_growth_bytes > MEMORY_LIMIT_BYTES:
        p.append("memory")


def _topics_of(path: Path) -> Counter:
    with open(path, "rb") as fh:
        reader = make_reader(fh, validate_crcs=True)
        return Counter(ch.topic for _, ch, _ in reader.iter_messages(log_time_order=False))


def _judge_recovered(run: Run, recovered: Path, good_topics: set[str]) -> None:
    f = run.file
    if run.code != 0:
        if f.intact_messages > 0 and f.family != "layout":
            run.problems.append("lost intact chunks")
        return
    try:
        topics = _topics_of(recovered)
    except Exception as exc:  # the official reader cannot read it: a bad output
        run.problems.append(f"unreadable output ({type(exc).__name__})")
        return
    if sum(topics.values()) < f.intact_messages:
        run.problems.append("lost intact chunks")
    if f.byte_damage and not set(topics) <= good_topics:
        run.problems.append("garbled topic")
    with McapFile(recovered) as again:
        if again.damage or again.notes:
            run.problems.append("output not clean")


@pytest.fixture(scope="module")
def sources(tmp_path_factory):
    folder = tmp_path_factory.mktemp("good")
    cams, plain = folder / "cams.mcap", folder / "plain.mcap"
    record_flight(cams, cameras=True, size=(160, 120), script=CAMERA_SCRIPT)
    record_flight(plain, cameras=False, script=PLAIN_SCRIPT)
    return [("cams", cams), ("plain", plain)]


@pytest.fixture(scope="module")
def corpus(sources, tmp_path_factory):
    folder = tmp_path_factory.mktemp("corpus")
    return make_corpus(sources, folder)


def _table(runs: list[Run]) -> str:
    rows = ["command  runs  seconds  clean  tracebacks  other problems"]
    for cmd in COMMANDS:
        mine = [r for r in runs if r.command == cmd.name]
        clean = sum(not r.problems for r in mine)
        tracebacks = sum("traceback" in r.problems for r in mine)
        others = Counter(p for r in mine for p in r.problems if p != "traceback")
        rows.append(
            f"{cmd.name:8s} {len(mine):5d} {sum(r.seconds for r in mine):8.0f} {clean:6d} {tracebacks:11d}  "
            + (", ".join(f"{k} {v}" for k, v in sorted(others.items())) or "-")
        )
    total = len(runs)
    rows.append(
        f"{'all':8s} {total:5d} {sum(r.seconds for r in runs):8.0f} {sum(not r.problems for r in runs):6d} "
        f"{sum('traceback' in r.problems for r in runs):11d}"
    )
    kinds = Counter(r.exception.split(":")[0] for r in runs if r.exception and r.exception != "Hang")
    if kinds:
        rows.append("escaped: " + ", ".join(f"{k} {v}" for k, v in kinds.most_common()))
    return "\n".join(rows)


def _run_share(share: tuple[list[tuple[int, Damaged]], set[str], Path]) -> tuple[list[Run], float]:
    """Every command over one share of the corpus (in a worker process; each file with its place
    in its family): the runs, and how much that process's peak memory grew (MB)."""
    files, good_topics, tmp_path = share
    runs: list[Run] = []
    rss_before = _max_rss_bytes()
    for rank, f in files:
        for cmd in COMMANDS:
            if rank % cmd.every:
                continue
            work = tmp_path / f"{f.path.stem}_{cmd.name}"
            work.mkdir()
            with _window_for_three_frames() if cmd.name == "window" else contextlib.nullcontext():
                code, out, err, exc, seconds, grew = run_in_process(cmd.argv(f.path, work))
            run = Run(cmd.name, f, code, out, err, exc, seconds, grew, [])
            _judge(cmd, run)
            if cmd.name == "recover":
                _judge_recovered(run, work / "recovered.mcap", good_topics)
            runs.append(run)
    return runs, (_max_rss_bytes() - rss_before) / 2**20


def test_every_read_command_over_the_corpus(corpus, sources, tmp_path, capsys):
    good_topics = set().union(*(_topics_of(p) for _, p in sources))
    # the corpus in two interleaved shares, one per core, each in a process of its own (forked:
    # every run is in-process there, as here, with its own time limit and memory accounting)
    ranked, seen = [], Counter()  # each file with its place in its family (and source)
    for f in corpus:
        ranked.append((seen[f.family, f.source], f))
        seen[f.family, f.source] += 1
    shares = [(ranked[k::2], good_topics, tmp_path) for k in range(2)]
    with multiprocessing.get_context("fork").Pool(2) as pool:
        results = pool.map(_run_share, shares)
    runs = sorted((r for share_runs, _ in results for r in share_runs), key=lambda r: r.file.path.name)
    grew_mb = max(grew for _, grew in results)
    table = _table(runs)
    with capsys.disabled():
        print(f"\ndamaged corpus: {len(corpus)} files x {len(COMMANDS)} commands; peak memory grew {grew_mb:.0f} MB")
        print(table)
    families = {f.family for f in corpus}
    for cmd in COMMANDS:  # every command met every kind of damage
        assert {r.file.family for r in runs if r.command == cmd.name} == families, cmd.name
    bad = [r for r in runs if r.problems]
    detail = "\n".join(
        f"{r.command:8s} {r.file.path.name}: {', '.join(r.problems)}"
        + (f" [{r.exception}]" if r.exception else "")
        + (f" {r.err.strip().splitlines()[-1][:160]}" if r.err.strip() and not r.exception else "")
        for r in bad[:60]
    )
    assert not bad, f"{len(bad)} runs went wrong:\n{table}\n{detail}"
    assert grew_mb < MEMORY_LIMIT_BYTES / 2**20


def test_a_sample_as_real_processes(corpus, tmp_path):
    """Exit codes and stderr as a user sees them: `info` on one file of each family, `check` and
    `recover` on a few."""
    sample: dict[str, Damaged] = {}
    for f in corpus:
        sample.setdefault(f.family, f)
    runs = [["info", str(f.path)] for f in sample.values()]
    for f in list(sample.values())[:3]:
        runs += [["check", str(f.path)], ["recover", str(f.path), "-o", str(tmp_path / f"{f.path.stem}.mcap")]]
    for argv in runs:
        real = subprocess.run(
            [sys.executable, str(ROOT / "main.py"), *argv], capture_output=True, text=True, cwd=ROOT, timeout=120
        )
        if argv[0] == "recover":
            Path(argv[-1]).unlink(missing_ok=True)
        code, _, err, exc, _, _ = run_in_process(argv)
        assert exc is None and real.returncode == code, (argv, real.stderr)
        assert "Traceback" not in real.stderr
        if real.returncode and argv[0] != "check":
            assert real.stderr.strip().splitlines()[-1].startswith("quadsim: error: ")
