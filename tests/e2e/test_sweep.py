"""`quadsim sweep`: the runs a sweep file stands for, flown on one process, a pool and Ray, give
the same table; limits decide the exit code; Ctrl-C at random moments keeps every finished run
and --resume completes the table to what an uninterrupted sweep gives."""

from __future__ import annotations

import os
import random
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from quadsim.apps.sweep.metrics import METRICS
from quadsim.apps.sweep.table import existing_table, read_table
from quadsim.core.invocation import install_extra
from quadsim.recording.flight import load_flight
from tests.helpers import ROOT, default_core
from tests.helpers import proc as procfs
from tests.helpers.cli import run_main, wait_for_line
from tests.helpers.fleets import fleet_toml, vehicle

SMALL = """
name = "small"
scenarios = ["hover", "step_forward"]
duration_s = 6.0

[controllers.cascade]
kind = "cascade"
[controllers.seed]
kind = "seed"
[controllers.slow]
kind = "cascade"
gains = { velocity_p_xy_per_s = 0.8 }

[limits]
max_tilt_deg = 45
"""


def _sweep(
    tmp_path: Path, text: str, *args: str, name: str = "spec.toml", timeout: float = 300
) -> subprocess.CompletedProcess:
    spec = tmp_path / name
    spec.write_text(text)
    return subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "sweep", str(spec), *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=tmp_path,
    )


def _write(tmp_path: Path, text: str, name: str = "spec.toml") -> Path:
    spec = tmp_path / name
    spec.write_text(text)
    return spec


def _group_members(pgid: int) -> str:
    return subprocess.run(
        ["ps", "-o", "pid,args", "--no-headers", "-g", str(pgid)], capture_output=True, text=True
    ).stdout


def _group_gone(pgid: int, wait_s: float = 5.0) -> bool:
    """True once no process of the group is left (multiprocessing's resource tracker may take a
    moment to see its parent gone)."""
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.05)
    return False


def test_pool_and_one_process_give_the_same_table(tmp_path: Path) -> None:
    one = _sweep(tmp_path, SMALL, "--jobs", "1", "--out", str(tmp_path / "one"), "--format", "csv", "--no-plot")
    two = _sweep(tmp_path, SMALL, "--jobs", "2", "--out", str(tmp_path / "two"), "--format", "csv")
    assert one.returncode == 0, one.stderr
    assert two.returncode == 0, two.stderr
    a, b = (tmp_path / "one" / "results.csv").read_bytes(), (tmp_path / "two" / "results.csv").read_bytes()
    assert a == b
    rows = read_table(tmp_path / "two" / "results.csv")
    assert [r["index"] for r in rows] == list(range(6)) and all(r["status"] == "ok" for r in rows)
    by = {(r["scenario"], r["controller"]): r for r in rows}
    # the metrics measure the flights: the cascade holds a hover tighter than the seed controller,
    # a softer velocity gain tracks the step worse, a step tilts the vehicle and a hover does not
    assert by["hover", "cascade"]["end_drift_m"] < by["hover", "seed"]["end_drift_m"]
    assert by["step_forward", "slow"]["tracking_rms_mps"] > by["step_forward", "cascade"]["tracking_rms_mps"]
    assert by["step_forward", "cascade"]["max_tilt_deg"] > 5 > by["hover", "cascade"]["max_tilt_deg"]
    assert set(METRICS) <= set(rows[0])
    assert re.search(r"^hover\s+cascade\s+1\s", two.stdout, re.M) and "6 runs: 6 ok" in two.stdout
    png = tmp_path / "two" / "plot.png"
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"


def test_parquet_table_equals_the_csv_one(tmp_path: Path) -> None:
    pytest.importorskip("pyarrow", reason="pyarrow (the parquet extra) is not installed")
    text = SMALL.replace('["hover", "step_forward"]', '["hover"]')
    assert (
        _sweep(tmp_path, text, "--jobs", "1", "--out", str(tmp_path / "c"), "--format", "csv", "--no-plot").returncode
        == 0
    )
    assert (
        _sweep(
            tmp_path, text, "--jobs", "1", "--out", str(tmp_path / "p"), "--format", "parquet", "--no-plot"
        ).returncode
        == 0
    )
    csv_rows, parquet_rows = read_table(tmp_path / "c" / "results.csv"), read_table(tmp_path / "p" / "results.parquet")
    assert [repr(r) for r in csv_rows] == [repr(r) for r in parquet_rows]  # repr: NaN equals NaN


def test_the_wind_example_on_ray_and_on_the_pool_gives_the_docs_table(tmp_path: Path) -> None:
    """examples/sweep_wind.toml (the docs' sweep page) on a process pool and on a local Ray instance
    with two workers: the same table, and the summary docs/sweeps.md shows."""
    pytest.importorskip("ray", reason="Ray (the ray extra) is not installed")
    spec = str(ROOT / "examples" / "sweep_wind.toml")
    common = ["--format", "csv", "--no-plot"]
    pool = _run("sweep", spec, "--jobs", "2", "--out", str(tmp_path / "pool"), *common)
    ray = _run("sweep", spec, "--ray", "--jobs", "2", "--out", str(tmp_path / "ray"), *common)
    assert pool.returncode == ray.returncode == 1, ray.stderr[-2000:]  # the seed controller drifts off
    assert "on Ray (local, 2 CPUs)" in ray.stdout
    assert (tmp_path / "pool" / "results.csv").read_bytes() == (tmp_path / "ray" / "results.csv").read_bytes()
    rows = read_table(tmp_path / "pool" / "results.csv")
    cascade = [r for r in rows if r["controller"] == "cascade"]
    seed = [r for r in rows if r["controller"] == "seed"]
    assert all(r["status"] == "ok" for r in cascade) and all(r["failed_limits"] == "end_drift_m" for r in seed)
    # the seed decides the turbulence: three seeds, three different flights, in every wind
    for wind in ("0,90", "6,90"):
        assert len({r["end_drift_m"] for r in cascade if r["wind"] == wind}) == 3
    # more wind, more tilt to hold against it
    tilt = {w: sum(r["max_tilt_deg"] for r in cascade if r["wind"] == w) for w in ("0,90", "6,90")}
    assert tilt["6,90"] > tilt["0,90"]
    sweeps_page = (ROOT / "docs" / "sweeps.md").read_text()
    block = sweeps_page.split("$ .venv/bin/python main.py sweep examples/sweep_wind.toml", 1)[1].split("```", 1)[0]
    shown = [line for line in block.strip().splitlines()[2:] if not line.startswith(("table", "plot"))]
    printed = [line for line in pool.stdout.splitlines()[1:] if not line.startswith(("table", "plot"))]
    assert printed == shown


def _run(*args: str) -> subprocess.CompletedProcess:
    return run_main(*args, cwd=ROOT, timeout=600)


def test_limits_fail_runs_and_only_failures_are_recorded(tmp_path: Path) -> None:
    text = SMALL.replace("max_tilt_deg = 45", "max_tilt_deg = 5")
    done = _sweep(
        tmp_path, text, "--jobs", "2", "--out", str(tmp_path / "o"), "--format", "csv", "--record-failures", "--no-plot"
    )
    assert done.returncode == 1, done.stderr
    rows = read_table(tmp_path / "o" / "results.csv")
    failed = [r for r in rows if r["status"] == "fail"]
    assert failed and all(r["scenario"] == "step_forward" and r["failed_limits"] == "max_tilt_deg" for r in failed)
    assert all(r["status"] == "ok" for r in rows if r["scenario"] == "hover")
    kept = sorted((tmp_path / "o" / "recordings").glob("*.mcap"))
    assert len(kept) == len(failed)
    assert sorted(Path(r["recording"]).name for r in failed) == [p.name for p in kept]
    check = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "check", str(tmp_path / "o" / "recordings"), "--jobs", "2"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert check.returncode == 0, check.stdout + check.stderr  # each kept failure re-flies exactly
    assert f"{len(kept)} of {len(kept)} recordings re-fly" in check.stdout


def test_existing_table_needs_resume(tmp_path: Path) -> None:
    text = SMALL.replace('["hover", "step_forward"]', '["hover"]')
    out = str(tmp_path / "o")
    assert _sweep(tmp_path, text, "--jobs", "1", "--out", out, "--format", "csv", "--no-plot").returncode == 0
    again = _sweep(tmp_path, text, "--jobs", "1", "--out", out, "--no-plot")
    assert again.returncode == 2 and "--resume" in again.stderr
    assert not again.stdout  # refused before the sweep says anything
    resumed = _sweep(tmp_path, text, "--jobs", "1", "--out", out, "--resume", "--no-plot")
    assert resumed.returncode == 0 and "(3 of 3 runs; 3 already in the table)" in resumed.stdout
    assert "--overwrite" in again.stderr
    replaced = _sweep(tmp_path, text, "--jobs", "1", "--out", out, "--overwrite", "--no-plot")
    assert replaced.returncode == 0 and "already in the table" not in replaced.stdout
    assert "(3 of 3 runs)" in replaced.stdout and len(read_table(existing_table(tmp_path / "o"))) == 3


def test_resume_flies_again_what_the_sweep_file_changed_and_judges_by_todays_limits(tmp_path: Path) -> None:
    """--resume kept a 2 s run's row after duration_s became 30, and kept its verdict after the
    limits tightened (exit 0 where the table said 'beyond limits'): a row is kept only when its
    scenario, gains and duration are the same, and is judged by the limits of the file as it is."""
    (tmp_path / "up.qscript").write_text("z_mode velocity\n3.0 linear.z=0.5\n")
    text = SMALL.replace('["hover", "step_forward"]', '["up.qscript"]').replace("duration_s = 6.0", "duration_s = 2.0")
    out = tmp_path / "o"
    args = ("--jobs", "1", "--out", str(out), "--format", "csv", "--no-plot")
    assert _sweep(tmp_path, text, *args).returncode == 0
    first = {r["key"]: r for r in read_table(out / "results.csv")}

    def resumed(new_text: str) -> tuple[subprocess.CompletedProcess, dict[str, dict]]:
        done = _sweep(tmp_path, new_text, *args, "--resume")
        return done, {r["key"]: r for r in read_table(out / "results.csv")}

    done, rows = resumed(text)  # nothing changed: every row kept as it was
    assert done.returncode == 0 and "; 3 already in the table)" in done.stdout
    assert [repr(rows[k]) for k in sorted(rows)] == [repr(first[k]) for k in sorted(first)]  # nan == nan
    longer = text.replace("duration_s = 2.0", "duration_s = 3.0")
    done, rows = resumed(longer)
    assert "(3 of 3 runs; 3 flown again: their scenario, gains or duration changed since)" in done.stdout
    assert all(rows[k]["max_altitude_m"] > first[k]["max_altitude_m"] + 0.3 for k in rows)  # 1 s more climbing
    slower = longer.replace("velocity_p_xy_per_s = 0.8", "velocity_p_xy_per_s = 0.7")
    done, rows = resumed(slower)  # one controller's gains: its row alone
    assert "; 2 already in the table; 1 flown again" in done.stdout, done.stdout
    (tmp_path / "up.qscript").write_text("# climb\nz_mode velocity\n\n3.0 linear.z=0.5  # slowly\n")
    done, rows = resumed(slower)  # a comment changes nothing flown: nothing flies again
    assert "; 3 already in the table)" in done.stdout, done.stdout
    (tmp_path / "up.qscript").write_text("z_mode velocity\n3.0 linear.z=0.4\n")
    done, rows = resumed(slower)  # what the script flies: every row
    assert "; 3 flown again" in done.stdout, done.stdout
    tight = slower.replace("max_tilt_deg = 45", "max_altitude_m = 1.0")
    done, rows = resumed(tight)  # the limits: judged again, nothing flown
    assert done.returncode == 1 and "; 3 already in the table)" in done.stdout, done.stdout
    assert {r["status"] for r in rows.values()} == {"fail"} and {r["failed_limits"] for r in rows.values()} == {
        "max_altitude_m"
    }


def test_runs_flown_again_replace_their_recordings(tmp_path: Path) -> None:
    """With --record, a run flown again by --resume or --overwrite found its old recording in the
    way: every such run 'could not fly' and its good row became an error."""
    text = 'name = "r"\nscenarios = ["takeoff"]\nduration_s = 2.0\n[controllers.seed]\nkind = "seed"\n'
    out = tmp_path / "o"
    args = ("--jobs", "1", "--out", str(out), "--format", "csv", "--no-plot", "--record")
    assert _sweep(tmp_path, text, *args).returncode == 0
    (recording,) = (out / "recordings").glob("*.mcap")
    longer = text.replace("duration_s = 2.0", "duration_s = 3.0")
    for extra in ("--resume", "--overwrite"):
        done = _sweep(tmp_path, longer, *args, extra)
        assert done.returncode == 0 and "1 run: 1 ok" in done.stdout, done.stdout + done.stderr
        assert "1 flown again" in done.stdout or extra == "--overwrite"
    assert [p.name for p in (out / "recordings").glob("*.mcap")] == [recording.name]
    assert load_flight(recording).duration_s == pytest.approx(3.0, abs=0.05)  # the newest flight's, not 2 s
    checked = subprocess.run([sys.executable, str(ROOT / "main.py"), "check", str(recording)], capture_output=True)
    assert checked.returncode == 0


def test_ctrl_c_at_random_moments_keeps_finished_runs_and_resume_completes(tmp_path: Path) -> None:
    text = "seeds = 3\n" + SMALL.replace("duration_s = 6.0", "duration_s = 15.0")  # 18 runs
    reference = _sweep(tmp_path, text, "--jobs", "2", "--out", str(tmp_path / "ref"), "--format", "csv", "--no-plot")
    assert reference.returncode == 0, reference.stderr
    ref_bytes = (tmp_path / "ref" / "results.csv").read_bytes()
    # each trial's moment comes from its own progress: its line at a quarter, half or three
    # quarters of the runs, at once (four trials: a quarter of the runs is still to fly, however
    # fast or busy the machine) or a random moment up to 0.5 s after it; or up to a second after
    # its start (the sweep starting up). Only the first four must meet the sweep in flight.
    anchors = [
        ("sweep:", 1, 0.0, 0.0),
        ("sweep:", 2, 0.0, 0.0),
        ("sweep:", 3, 0.0, 0.0),
        ("sweep:", 3, 0.0, 0.0),
        ("sweep:", 2, 0.0, 0.5),
        (None, 1, 0.3, 1.0),
    ]
    rng = random.Random(13)
    spec = tmp_path / "spec.toml"
    interrupted = 0
    for trial in range(6):
        out = tmp_path / f"t{trial}"
        signum = rng.choice([signal.SIGINT, signal.SIGTERM])
        proc = subprocess.Popen(
            [
                sys.executable,
                str(ROOT / "main.py"),
                "sweep",
                str(spec),
                "--jobs",
                "2",
                "--out",
                str(out),
                "--format",
                "csv",
                "--no-plot",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
        line, count, low, high = anchors[trial]
        _, errs, readers = wait_for_line(proc, line, count)
        if high:  # the moment: at random after the line; no outcome depends on its length
            time.sleep(rng.uniform(low, high))
        os.killpg(proc.pid, signum)  # as a terminal's Ctrl-C does: the whole group
        proc.wait(timeout=120)
        for reader in readers:
            reader.join(timeout=30)
        stderr = "".join(errs)
        assert "Traceback" not in stderr, stderr
        if proc.returncode == 0:  # it had finished: nothing to resume
            assert (out / "results.csv").read_bytes() == ref_bytes
            continue
        assert proc.returncode == 128 + signum, (proc.returncode, stderr)
        if trial < 4:
            interrupted += 1
        assert _group_gone(proc.pid), _group_members(proc.pid)  # no worker left behind
        if (out / "results.csv").exists():
            rows = read_table(out / "results.csv")
            assert all(r["status"] == "ok" for r in rows)
            if len(rows) < 18:  # stopped with runs left: it says how to fly them
                assert "--resume flies the" in stderr
        resumed = _sweep(tmp_path, text, "--jobs", "2", "--out", str(out), "--resume", "--no-plot")
        assert resumed.returncode == 0, resumed.stderr
        assert (out / "results.csv").read_bytes() == ref_bytes
    assert interrupted == 4  # the moments at a progress line fell inside the sweep, not after it


TRIO = fleet_toml(
    vehicle("alpha", (0.0, 0.0, 0.0, 0.0), input="script:square"),
    vehicle("bravo", (0.0, -4.0, 0.0, 0.0), airframe="hexa", input="script:yaw"),
    vehicle("charlie", (-4.0, 0.0, 0.0, 0.0), input="idle"),
)


def test_a_fleet_file_is_a_scenario_whose_row_is_its_worst_vehicle(tmp_path: Path) -> None:
    """A fleet in a sweep: flown whole in each run, over wind and seeds, beside a plain scenario;
    its row holds each metric's largest over its vehicles (computed again here by flying the same
    fleet), a broken limit names the vehicle, the pool gives the table one process gives, and its
    recording re-flies at zero as a fleet."""
    from quadsim.apps.plans import fleet_drivers
    from quadsim.apps.sweep.metrics import flight_metrics
    from quadsim.physics.wind import wind_from_text
    from quadsim.sim.config import SimConfig
    from quadsim.sim.fleet import Fleet
    from quadsim.sim.fleet_file import load_fleet_file
    from quadsim.sim.loop import StateLog

    (tmp_path / "trio.toml").write_text(TRIO)
    text = 'scenarios = ["hover", "trio.toml"]\nduration_s = 6.0\nwind = ["0,0", "2,90"]\n[limits]\nmax_tilt_deg = 8\n'
    outs = {}
    for jobs in ("1", "2"):
        done = _sweep(
            tmp_path, text, "--jobs", jobs, "--out", str(tmp_path / jobs), "--format", "csv", "--no-plot", "--record"
        )
        assert done.returncode in (0, 1), done.stdout + done.stderr
        outs[jobs] = (tmp_path / jobs / "results.csv").read_text()
    assert outs["1"].replace(str(tmp_path / "1"), "") == outs["2"].replace(str(tmp_path / "2"), "")
    rows = read_table(tmp_path / "1" / "results.csv")
    fleet_rows = [r for r in rows if r["scenario"] == "trio.toml"]
    assert len(rows) == 4 and len(fleet_rows) == 2
    assert all(r["airframe"] == "per vehicle" and r["controller"] == "per vehicle" for r in fleet_rows)
    windy = next(r for r in fleet_rows if r["wind"] == "2,90")
    fleet_file = load_fleet_file(tmp_path / "trio.toml")
    config = SimConfig(wind=wind_from_text("2,90", "none"), seed=0)
    with Fleet(fleet_file.fleet_vehicles(fleet_drivers(fleet_file)), config) as fleet:
        logs = {name: StateLog() for name in fleet}
        for name, log in logs.items():
            fleet[name].add_sink(log)
        fleet.run_for(6.0)
        each = {n: flight_metrics(log.states, log.commands, 240, fleet[n].events) for n, log in logs.items()}
    for metric in ("max_tilt_deg", "max_altitude_m", "distance_m"):
        assert float(windy[metric]) == pytest.approx(max(m[metric] for m in each.values()), rel=1e-9), metric
    tilted = max(each, key=lambda n: each[n]["max_tilt_deg"])
    assert windy["status"] == "fail" and windy["failed_limits"] == f"max_tilt_deg ({tilted})"
    check = _run("check", windy["recording"], "--tolerance-m", "0", "--tolerance-rad", "0")
    assert check.returncode == 0 and "(a fleet of 3)" in check.stdout, check.stdout + check.stderr


NO_NUMBA = (
    "import runpy, sys; sys.modules['numba'] = None; "  # as if the fast extra were not installed
    "sys.argv = ['main.py', *sys.argv[1:]]; runpy.run_path(sys.argv[0], run_name='__main__')"
)


def test_without_numba_a_long_sweep_says_how_to_fly_it_faster_and_a_short_one_does_not(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The compiled core costs each worker a quarter to half a second to load: it pays on long sweeps,
    not on short ones (where the note would be bad advice)."""
    said = {}
    for seconds in (30, 700):
        spec = _write(
            tmp_path, f'name = "s{seconds}"\nscenarios = ["hover"]\nduration_s = {seconds}\n', f"s{seconds}.toml"
        )
        done = subprocess.run(
            [sys.executable, "-c", NO_NUMBA, "sweep", str(spec), "--jobs", "1", "--out", str(tmp_path / f"o{seconds}")],
            capture_output=True,
            text=True,
            timeout=300,
            cwd=ROOT,
            env=default_core(os.environ),  # numba gone, not set aside
        )
        assert done.returncode == 0, done.stderr[-2000:]
        said[seconds] = done.stdout.splitlines()[1]
    assert not said[30].startswith("note:")
    monkeypatch.chdir(ROOT)  # where it ran: the hint is the clone's install command there
    assert said[700] == f"note: flight core as plain Python: {install_extra('fast')} (numba) to compile it"


POOL_SCRIPT = """
import sys, threading, time
from quadsim.apps.sweep.backends import run_pool, start_method

LOADED_HERE = []  # filled after the imports: a spawned worker, importing this file afresh, has it empty

def task(i):
    return i * i, len(LOADED_HERE)

if __name__ == "__main__":
    LOADED_HERE.append("set in the parent")
    if sys.argv[1] == "thread":  # another thread, as a live bridge or a user's program may run
        stop = threading.Event()
        threading.Thread(target=stop.wait, daemon=True).start()
    elif sys.argv[1] == "numpy":  # OpenBLAS's threads, started by numpy's import (not Python's)
        import numpy
    print(start_method(), "written before the pool", end=" ")  # left in the buffer: stdout is a pipe
    print(sorted(run_pool(task, list(range(6)), 2)))
"""


@pytest.mark.parametrize(
    ("threads", "blas_threads", "method", "inherited"),
    [("none", "", "fork", 1), ("thread", "", "spawn", 0), ("numpy", "", "spawn", 0), ("numpy", "1", "fork", 1)],
)
def test_pool_workers_fork_from_a_single_threaded_process_and_spawn_beside_threads(
    tmp_path: Path, threads: str, blas_threads: str, method: str, inherited: int
) -> None:
    """Forked workers start with what the sweep's process loaded (no half second of imports each);
    beside a thread they are spawned. Either way the results are the same, and what the process
    had not yet written out is written once (a forked worker must not flush a copy of it)."""
    script = tmp_path / "pool.py"
    script.write_text(POOL_SCRIPT)
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if blas_threads:
        env["OPENBLAS_NUM_THREADS"] = blas_threads
    done = subprocess.run(
        [sys.executable, str(script), threads], capture_output=True, text=True, timeout=120, cwd=ROOT, env=env
    )
    assert done.returncode == 0, done.stderr
    squares = [(i * i, inherited) for i in range(6)]
    assert done.stdout == f"{method} written before the pool {squares}\n"


def test_resume_flies_a_fleet_again_when_its_own_airframe_files_change(tmp_path: Path) -> None:
    """A fleet vehicle on an airframe of the user's own: an edit to its URDF's parameter or gains
    file (beside the URDF) flies the fleet's runs again on --resume; the plain runs stay kept."""
    import shutil

    shipped = ROOT / "quadsim" / "assets" / "urdf"
    for suffix in (".urdf", ".params.toml"):
        shutil.copy(shipped / f"quadsim_x{suffix}", tmp_path / f"mine{suffix}")
    (tmp_path / "duo.toml").write_text(
        '[[vehicle]]\nname = "own"\nairframe = "mine.urdf"\ninput = "script:hover"\n\n'
        '[[vehicle]]\nname = "stock"\nstart = [0.0, -4.0, 0.0, 0.0]\ninput = "idle"\n'
    )
    text = 'scenarios = ["hover", "duo.toml"]\nduration_s = 2.0\n'
    args = ("--jobs", "1", "--out", str(tmp_path / "o"), "--format", "csv", "--no-plot")
    assert _sweep(tmp_path, text, *args).returncode == 0
    done = _sweep(tmp_path, text, *args, "--resume")
    assert "; 2 already in the table)" in done.stdout, done.stdout
    params = tmp_path / "mine.params.toml"
    params.write_text(params.read_text().replace("max_climb_rate_mps = 2.5", "max_climb_rate_mps = 2.0"))
    done = _sweep(tmp_path, text, *args, "--resume")
    assert "; 1 already in the table; 1 flown again" in done.stdout, done.stdout
    gains = (shipped / "quadsim_x.gains.toml").read_text()  # a gains file of its own, where it flew the defaults
    (tmp_path / "mine.gains.toml").write_text(gains.replace("position_p_per_s = 2.0", "position_p_per_s = 1.5"))
    done = _sweep(tmp_path, text, *args, "--resume")
    assert "; 1 already in the table; 1 flown again" in done.stdout, done.stdout
    done = _sweep(tmp_path, text, *args, "--resume")
    assert "; 2 already in the table)" in done.stdout, done.stdout


def _workers_of(pid: int) -> list[int]:
    """The pool's worker processes: the children of `pid` running Python, not the resource tracker.
    Read from /proc, not `ps`: piped, `ps` cuts its lines at 80 columns, and under a long enough
    interpreter path the tracker's name fell past the cut and it was counted as a worker."""
    workers = []
    for child in procfs.pids():
        try:
            parent, line = procfs.parent_of(child), procfs.cmdline(child)
        except OSError:  # gone meanwhile
            continue
        if parent == pid and b"resource_tracker" not in line:
            workers.append(child)
    return sorted(workers)


def _long_sweep(tmp_path: Path) -> subprocess.Popen:
    """Two runs of an hour of flight on two workers (a minute or more each on this machine)."""
    spec = _write(tmp_path, 'name = "long"\nscenarios = ["hover"]\nduration_s = 3600\nseeds = 2\n', "long.toml")
    proc = subprocess.Popen(
        [sys.executable, str(ROOT / "main.py"), "sweep", str(spec), "--jobs", "2", "--out", str(tmp_path / "o")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    deadline = time.monotonic() + 60
    while len(_workers_of(proc.pid)) < 2 and time.monotonic() < deadline:
        time.sleep(0.1)  # polling for the workers, with a deadline
    assert len(_workers_of(proc.pid)) == 2, _group_members(proc.pid)
    return proc


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_second_signal_abandons_the_runs_in_flight(tmp_path: Path, signum: int) -> None:
    """The first Ctrl-C waits for the runs in flight, a second one abandons them: the workers are
    killed (they ignore the signals themselves), the exit is 130 or 143 with one line saying so,
    and nothing is left running. (The abandon path raised AttributeError and then waited for the
    runs, an hour of flight each, to end; and a second line said nothing had been cut short.)"""
    proc = _long_sweep(tmp_path)
    for worker in _workers_of(proc.pid):  # the command line forks them: they run main.py, not a spawn
        assert b"main.py\0sweep" in Path(f"/proc/{worker}/cmdline").read_bytes()
    os.killpg(proc.pid, signum)
    # the second once the first has been taken (the sweep says it stops at the next safe point)
    _, errs, readers = wait_for_line(proc, "quadsim: stopping at the next safe point", 1)
    os.killpg(proc.pid, signum)
    # the runs in flight had an hour of flight left: ending within the timeout means they were killed
    proc.wait(timeout=120)
    for reader in readers:
        reader.join(timeout=30)
    stderr = "".join(errs)
    assert proc.returncode == 128 + signum, stderr
    assert "Traceback" not in stderr and "Error" not in stderr and "nothing was cut short" not in stderr, stderr
    assert stderr.strip().endswith(f"quadsim: {'interrupted' if signum == signal.SIGINT else 'terminated'}"), stderr
    assert _group_gone(proc.pid), _group_members(proc.pid)


def test_a_worker_killed_from_outside_ends_the_sweep_with_one_line(tmp_path: Path) -> None:
    """A worker killed by the kernel (out of memory, kill -9): exit 2 and one line naming it,
    no traceback, no process left."""
    proc = _long_sweep(tmp_path)
    os.kill(_workers_of(proc.pid)[0], signal.SIGKILL)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 2, stderr
    assert stderr.strip().splitlines()[-1].startswith("quadsim: error: a worker process failed: BrokenProcessPool")
    assert "Traceback" not in stderr, stderr
    assert _group_gone(proc.pid), _group_members(proc.pid)


def test_a_pool_whose_reader_stops_early_kills_its_workers() -> None:
    """`check ... | head -1`, or a program that takes the first result and stops reading: the pool's
    workers are killed at once, not waited for, and no error comes out of closing it."""
    from quadsim.apps.sweep.backends import run_pool

    earlier = set(_workers_of(os.getpid()))  # what earlier tests in this process left running
    results = run_pool(time.sleep, [0.0, 0.0, 600.0, 600.0, 600.0], 2)
    assert next(results) is None
    children = [pid for pid in _workers_of(os.getpid()) if pid not in earlier]
    assert len(children) == 2, children
    results.close()  # GeneratorExit inside the pool (it raised AttributeError)
    for pid in children:
        deadline = time.monotonic() + 30
        while Path(f"/proc/{pid}").exists() and "zombie" not in _state(pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not Path(f"/proc/{pid}").exists() or "zombie" in _state(pid), pid


def _state(pid: int) -> str:
    try:
        return next(line for line in Path(f"/proc/{pid}/status").read_text().splitlines() if line.startswith("State:"))
    except (OSError, StopIteration):
        return "zombie"  # gone
