"""Crafted sweep, world and vehicle-parameter files through the real command line:
each gives one line on stderr and exit 2 (never a traceback), within 30 s and 300 MB, and writes
nothing outside the output folder, whatever names, depths and sizes the file holds."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from quadsim.vehicle.params import DEFAULT_URDF
from tests.helpers import ROOT

TIMEOUT_S = 30.0
MAX_RSS_MB = 300.0
NEST = 3000  # arrays within arrays: past the TOML parser's recursion


@dataclass(frozen=True)
class Case:
    name: str
    command: str  # sweep, world, params
    text: str  # the file's TOML
    says: str  # what the one line must hold


SWEEP_CASES = [
    Case("name_up_and_out", "sweep", 'name = "../../escaped"\nscenarios = ["hover"]\n', "'name' must be a plain"),
    Case("name_absolute", "sweep", 'name = "/tmp/quadsim_abs"\nscenarios = ["hover"]\n', "'name' must be a plain"),
    Case("name_nul", "sweep", 'name = "a\\u0000b"\nscenarios = ["hover"]\n', "'name' must be a plain"),
    Case("name_dot_dot", "sweep", 'name = ".."\nscenarios = ["hover"]\n', "'name' must be a plain"),
    Case("nested_scenarios", "sweep", "scenarios = " + "[" * NEST + "]" * NEST + "\n", "nested deeper than"),
    Case("nested_limits", "sweep", 'scenarios = ["hover"]\n[limits]\nx = ' + "[" * 20 + "]" * 20, "limits is nested"),
    Case(
        "many_names",
        "sweep",
        "scenarios = [" + ",".join(f'"s{i}"' for i in range(90_000)) + "]\n",
        "'scenarios' lists 90000 values",
    ),
    Case(
        "too_big",
        "sweep",
        "".join(f"# {'x' * 70}\n" for _ in range(20_000)) + 'scenarios = ["hover"]\n',
        "may be at most 1024 kB",
    ),
    Case("nan_limit", "sweep", 'scenarios = ["hover"]\n[limits]\nmax_tilt_deg = nan\n', "must be a finite number"),
    Case("inf_limit", "sweep", 'scenarios = ["hover"]\n[limits]\ncrashes = inf\n', "must be a finite number"),
    Case("endless_scenario", "sweep", 'scenarios = ["endless.qscript"]\n', "give duration_s to bound it"),
    Case(
        "too_many_runs",
        "sweep",
        'scenarios = ["hover"]\nseeds = 10000\nwind = [' + ",".join(f'"{s},0"' for s in range(11)) + "]\n",
        "110000 runs is more than 100000",
    ),
    Case("large_without_yes", "sweep", 'scenarios = ["hover"]\nseeds = 2000\n', "add --yes"),
    Case("duplicate_wind", "sweep", 'scenarios = ["hover"]\nwind = ["1,0", "1,0"]\n', "lists '1,0' twice"),
    Case("not_utf8", "sweep", "name = '\udcff'\n", "not a UTF-8 text file"),
]
WORLD_CASES = [
    Case("nested", "world", "[floor]\nsize_m = " + "[" * NEST + "]" * NEST + "\n", "nested deeper than"),
    Case(
        "nested_tables", "world", "".join(f"[{'.'.join('t' * 1 for _ in range(k + 1))}]\n" for k in range(40)), "t is"
    ),
    Case("too_big", "world", "# " + "x" * (1100 * 1024) + "\n", "may be at most 1024 kB"),
]
PARAMS_CASES = [Case("nested", "params", "x = " + "[" * NEST + "]" * NEST + "\n", "nested deeper than")]
CASES = SWEEP_CASES + WORLD_CASES + PARAMS_CASES


def _write(case: Case, folder: Path) -> Path:
    folder.mkdir()
    path = folder / "input.toml"
    path.write_bytes(case.text.encode("utf-8", "surrogateescape"))
    (folder / "endless.qscript").write_text("7200 linear.z=0.5\n")
    return path


def _argv(case: Case, path: Path, out: Path) -> list[str]:
    quick = ["--script", "hover", "--duration", "0.2", "--cameras", "none", "--out", str(out / "run.mcap")]
    if case.command == "sweep":
        return ["sweep", str(path), "--jobs", "1", "--no-plot"]
    if case.command == "world":
        return ["run", "--world", str(path), *quick]
    urdf = path.parent / "v.urdf"  # a vehicle whose parameter file is the crafted one
    urdf.write_text(DEFAULT_URDF.read_text())
    path.rename(urdf.with_suffix(".params.toml"))
    return ["run", "--urdf", str(urdf), *quick]


#: runs main.py and, as it exits, writes its peak RSS (kB) to $QUADSIM_TEST_PEAK. The kernel's
#: ru_maxrss cannot be used: a child's counts the memory of the process that started it (exec
#: keeps the high-water mark of the memory it replaces), so every child "peaked" at pytest's size.
PEAK_RECORDER = """
import atexit, os, runpy, sys

def _peak():
    with open("/proc/self/status") as status:
        kb = next(int(line.split()[1]) for line in status if line.startswith("VmHWM:"))
    with open(os.environ["QUADSIM_TEST_PEAK"], "w") as out:
        out.write(str(kb))

atexit.register(_peak)
sys.argv = sys.argv[1:]
runpy.run_path(sys.argv[0], run_name="__main__")
"""


def run_measured(
    argv: list[str], cwd: Path, env: dict[str, str], timeout_s: float = TIMEOUT_S
) -> tuple[int, str, float]:
    """Exit code, stderr and peak RSS (MB) of one run of quadsim in a process of its own, killed
    (-9) after `timeout_s`."""
    err_path, peak_path = cwd / "stderr.txt", cwd / "peak_kb.txt"
    with open(err_path, "w") as err:
        proc = subprocess.Popen(
            [sys.executable, "-c", PEAK_RECORDER, str(ROOT / "main.py"), *argv],
            cwd=cwd,
            env={**env, "QUADSIM_TEST_PEAK": str(peak_path)},
            stdout=subprocess.DEVNULL,
            stderr=err,
        )
        try:
            code = proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            code = proc.wait()
    peak_mb = int(peak_path.read_text()) / 1024 if peak_path.exists() else math.inf
    return code, err_path.read_text(), peak_mb


def test_the_peak_memory_measured_is_the_child_s_own(tmp_path: Path) -> None:
    """pytest itself past 300 MB made every child measured by ru_maxrss seem to peak there too."""
    ballast = bytearray(400 * 1024 * 1024)  # this process's own high-water mark goes past 400 MB
    ballast[::4096] = b"x" * len(ballast[::4096])
    (tmp_path / "cwd").mkdir()
    code, stderr, peak_mb = run_measured(["--version"], tmp_path / "cwd", dict(os.environ))
    del ballast
    assert code == 0, stderr
    assert 5 < peak_mb < 150


@pytest.mark.parametrize("case", CASES, ids=[f"{c.command}-{c.name}" for c in CASES])
def test_a_crafted_file_is_one_line_and_exit_2(case: Case, tmp_path: Path) -> None:
    inputs, out, cwd = tmp_path / "inputs", tmp_path / "out", tmp_path / "cwd"
    path = _write(case, inputs)
    out.mkdir()
    cwd.mkdir()
    env = {**os.environ, "QUADSIM_RECORDINGS": str(out / "recordings"), "SDL_VIDEODRIVER": "dummy"}
    env["SDL_AUDIODRIVER"] = "dummy"
    code, stderr, rss_mb = run_measured(_argv(case, path, out), cwd, env)
    assert code != -signal.SIGKILL, f"no answer in {TIMEOUT_S:.0f} s"
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and "Traceback" not in stderr, (code, stderr[-2000:])
    assert lines[0].startswith("quadsim: error: ") and case.says in lines[0], lines[0]
    assert len(lines[0]) < 400, lines[0]  # the line names the problem, it does not echo the file
    assert rss_mb < MAX_RSS_MB, rss_mb
    written = {p for p in tmp_path.rglob("*") if not p.is_relative_to(inputs)} - {
        out,
        cwd,
        cwd / "stderr.txt",
        cwd / "peak_kb.txt",
    }
    assert all(p.is_relative_to(out) for p in written), sorted(written)
    assert not [p for p in out.rglob("*") if p.is_file()], "a refused file flew something"
