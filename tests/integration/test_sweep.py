"""`quadsim sweep`.

Its integration tests (several layers, in-process or one process started); the others are in tests/e2e/test_sweep.py."""

from __future__ import annotations

import os
import random
import re
import subprocess
import sys
from pathlib import Path

import pytest

from quadsim.apps.sweep.spec import load_sweep
from quadsim.apps.sweep.table import read_table
from quadsim.errors import ConfigError, QuadsimError
from tests.e2e.test_sweep import _sweep, _write
from tests.helpers import ROOT


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ('scenarios = ["hover"]\nwhat = 1', "unknown key 'what' (a sweep file has "),
        ('scenario = ["hover"]', "unknown key 'scenario' (did you mean 'scenarios'?)"),
        ('[[vehicle]]\nname = "a"\n', "a fleet file, not a sweep file: fly it with 'run --fleet bad.toml'"),
        (
            'scenarios = ["hover"]\n[controllers.c]\nkynd = "seed"',
            "controllers.c: unknown key 'kynd' (did you mean 'kind'?)",
        ),
        (
            'scenarios = ["hover"]\n[controllers.c]\nkind = "cascade"\ngains = { altitude_p_per_ = 2 }',
            "unknown cascade gain 'altitude_p_per_' (did you mean 'altitude_p_per_s'?)",
        ),
        ('scenarios = ["nowhere"]', "unknown scenario 'nowhere'"),
        ('scenarios = ["hover"]\nairframes = ["tricopter"]', "unknown airframe 'tricopter'"),
        ('scenarios = ["hover"]\nseeds = 0', "'seeds' must be a whole number"),
        ('scenarios = ["hover"]\nwind = ["fast"]', "a wind must look like SPEED,FROM_DEG"),
        ('scenarios = ["hover"]\nturbulence = ["gusty"]', "is not one of none, light, moderate, severe"),
        (
            'scenarios = ["hover"]\n[controllers.c]\nkind = "cascade"\ngains = { speed = 2 }',
            "unknown cascade gain 'speed'",
        ),
        (
            'scenarios = ["hover"]\n[controllers.c]\nkind = "cascade"\ngains = { altitude_p_per_s = -1 }',
            r"controllers.c.gains.altitude_p_per_s = -1: expected a number >= 0",
        ),
        ('scenarios = ["hover"]\n[limits]\nwobble = 3', "limits.wobble: no such metric"),
        ('scenarios = ["hover"]\n[limits]\nwind = ["fast"]', "limits.wind: no such metric"),
        ('scenarios = ["hover"]\n[limits]\ncrashes = -1', "limits.crashes = -1: a limit is the highest value allowed"),
        ('scenarios = ["hover"', "not valid TOML"),
    ],
)
def test_a_bad_sweep_file_is_one_line_and_exit_2(tmp_path: Path, text: str, expected: str) -> None:
    spec = tmp_path / "bad.toml"
    spec.write_text(text)
    with pytest.raises(ConfigError, match=re.escape(expected)):
        load_sweep(spec)
    done = _sweep(tmp_path, text, "--out", str(tmp_path / "out"), name="bad.toml")
    assert done.returncode == 2, done.stderr
    assert expected.split("'")[0] in done.stderr and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1


def test_a_crash_and_a_landing_are_in_the_table(tmp_path: Path) -> None:
    """A script file beside the sweep file flies into the red tower (6 m ahead); another lands."""
    (tmp_path / "into_tower.qscript").write_text(
        "# into the tower\nz_mode height\n4.0 linear.z=1.5\n6.0 linear.x=2.0\n"
    )
    (tmp_path / "land.qscript").write_text("# up and down\nz_mode velocity\n2.0 linear.z=1.0\n8.0 linear.z=-1.0\n")
    text = 'scenarios = ["into_tower.qscript", "land.qscript"]\n[limits]\ncrashes = 0\n'
    done = _sweep(tmp_path, text, "--jobs", "1", "--out", str(tmp_path / "o"), "--format", "csv", "--no-plot")
    assert done.returncode == 1, done.stderr
    tower, land = read_table(tmp_path / "o" / "results.csv")
    assert tower["scenario"] == "into_tower.qscript" and tower["crashes"] >= 1 and tower["status"] == "fail"
    assert tower["failed_limits"] == "crashes"
    assert land["crashes"] == 0 and land["status"] == "ok"
    assert 0.0 < land["touchdown_speed_mps"] <= 0.5  # the landing layer's gentle touchdown


def test_a_sweep_where_no_run_can_fly_says_so_and_draws_no_plot(tmp_path):
    """Every run refused (the seed controller does not fly the Crazyflie): each run's error in
    the summary, the table kept, 'plot none' and exit 1 (it ended in matplotlib's traceback)."""
    (tmp_path / "cf.toml").write_text(
        'name = "cf"\nscenarios = ["takeoff"]\nairframes = ["crazyflie"]\n[controllers.seed]\nkind = "seed"\n'
    )
    done = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "sweep", str(tmp_path / "cf.toml"), "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
    assert "1 run: 0 ok, 0 beyond limits, 1 could not fly" in done.stdout and "1 run on" in done.stdout
    assert "plot            none: no run flew" in done.stdout and (tmp_path / "out" / "results.parquet").exists()


def test_a_broken_pyarrow_keeps_the_table_as_csv_and_says_so(tmp_path: Path) -> None:
    """pyarrow is found without importing it (its import starts threads, which rule out forking the
    workers); one that is found but does not import is said when the table is written, and what
    was flown is kept as CSV."""
    broken = tmp_path / "site" / "pyarrow"
    broken.mkdir(parents=True)
    (broken / "__init__.py").write_text('raise ImportError("libarrow.so.2000: cannot open shared object file")\n')
    spec = _write(tmp_path, 'name = "b"\nscenarios = ["hover"]\nduration_s = 2\nseeds = 2\n', "b.toml")
    done = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "sweep", str(spec), "--jobs", "2", "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "PYTHONPATH": str(tmp_path / "site")},
    )
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert "pyarrow is installed but does not import (libarrow.so.2000" in done.stderr, done.stderr
    rows = read_table(tmp_path / "o" / "results.csv")
    assert [r["status"] for r in rows] == ["ok", "ok"]
    assert not (tmp_path / "o" / "results.parquet").exists()


def test_a_table_that_cannot_be_saved_on_the_way_stops_no_run(tmp_path: Path, monkeypatch) -> None:
    """Saves on the way (here after every run) that fail, as a broken pyarrow's do, leave every
    run to fly; the last write says why and keeps the table as CSV. (A save after 2 s of a loaded
    machine's sweep used to end it with the runs left unflown.)"""
    from quadsim.apps.sweep import execute

    broken = tmp_path / "site" / "pyarrow"
    broken.mkdir(parents=True)
    (broken / "__init__.py").write_text('raise ImportError("libarrow.so.2000: cannot open shared object file")\n')
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    monkeypatch.delitem(sys.modules, "pyarrow", raising=False)
    monkeypatch.setattr(execute, "_SAVE_EVERY_S", -1.0)
    spec = load_sweep(_write(tmp_path, 'name = "b"\nscenarios = ["hover"]\nduration_s = 1\nseeds = 3\n', "b.toml"))
    with pytest.raises(QuadsimError, match="pyarrow is installed but does not import"):
        execute.run_sweep(spec, tmp_path / "o", table_format="parquet", progress=False)
    assert [r["status"] for r in read_table(tmp_path / "o" / "results.csv")] == ["ok", "ok", "ok"]


def test_a_worker_that_reuses_its_simulators_gives_the_rows_of_new_ones(tmp_path: Path, monkeypatch) -> None:
    """Runs restarted on a simulator kept from earlier runs (any order, other seeds, other
    scenarios and z-modes, a crash before) give the very rows a new simulator gives, and the
    world and vehicle are built once per airframe, controller and wind, not once per run."""
    from quadsim.apps.sweep import run as sweep_run
    from quadsim.apps.sweep.execute import hand_out_order
    from quadsim.sim.fleet import Fleet

    spec = _write(
        tmp_path,
        'scenarios = ["takeoff", "yaw", "climb"]\nairframes = ["quad", "crazyflie"]\nduration_s = 3.0\n'
        'seeds = 2\nwind = ["0,0", "4,45"]\nturbulence = ["light"]\n'
        '[controllers.cascade]\nkind = "cascade"\n[controllers.slow]\nkind = "cascade"\n'
        "gains = { velocity_p_xy_per_s = 0.8 }\n",
    )
    tasks = [sweep_run.RunTask(run) for run in load_sweep(spec).runs]
    built = []
    init = Fleet.__init__

    def counting_init(self, *args, **kwargs):
        built.append(1)
        init(self, *args, **kwargs)

    monkeypatch.setattr(Fleet, "__init__", counting_init)
    fresh = []
    for task in tasks:
        sweep_run.forget_simulators()
        fresh.append(sweep_run.fly_run(task))
    assert len(built) == len(tasks) == 48
    built.clear()
    try:
        reused = {row["index"]: row for row in map(sweep_run.fly_run, random.Random(7).sample(tasks, len(tasks)))}
    finally:
        sweep_run.forget_simulators()
    assert all(row["status"] in ("ok", "fail") for row in fresh), [r["error"] for r in fresh if r["error"]]
    assert [repr(reused[row["index"]]) for row in fresh] == [repr(row) for row in fresh]
    # handed out as a sweep hands them out, a worker builds one simulator per airframe, controller,
    # wind and z-mode (climb flies in velocity z-mode, the others in height): 2 x 2 x 2 x 2
    built.clear()
    try:
        in_order = [sweep_run.fly_run(task) for task in sorted(tasks, key=hand_out_order)]
    finally:
        sweep_run.forget_simulators()
    assert len(built) == 16
    assert sorted(map(repr, in_order)) == sorted(map(repr, fresh))


def test_no_more_workers_than_runs_and_an_out_that_is_a_file_is_refused_first(tmp_path: Path) -> None:
    """--jobs 1000 for 2 runs started 1000 worker processes (654 seen at once on 2 cores); --out
    naming a file printed the sweep's first line before its error."""
    text = 'scenarios = ["takeoff"]\nseeds = 2\n'
    done = _sweep(tmp_path, text, "--jobs", "1000", "--out", str(tmp_path / "o"), "--format", "csv", "--no-plot")
    assert done.returncode == 0, done.stderr
    assert "2 runs on 2 worker processes" in done.stdout, done.stdout
    (tmp_path / "taken.mcap").write_bytes(b"")
    refused = _sweep(tmp_path, text, "--out", str(tmp_path / "taken.mcap"), "--no-plot")
    assert refused.returncode == 2 and refused.stdout == "", refused.stdout
    assert "--out " in refused.stderr and "taken.mcap is a file: a sweep's results go in a folder" in refused.stderr
