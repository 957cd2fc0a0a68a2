"""A whole sweep: the runs not yet in the table are flown on the chosen back-end, the table is
rewritten as results arrive (at most every 2 s) and at the end, whatever ended it."""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from quadsim.apps.sweep.backends import run_tasks
from quadsim.apps.sweep.run import RunTask, fly_run, forget_simulators, judge, recording_path
from quadsim.apps.sweep.spec import SweepSpec
from quadsim.apps.sweep.table import existing_table, read_table, table_path, write_table
from quadsim.errors import QuadsimError
from quadsim.session.progress import Eta, ProgressBar
from quadsim.session.stopping import shielded_from_signals, stop_requested

_SAVE_EVERY_S = 2.0


@dataclass
class SweepResult:
    table: Path
    rows: list[dict[str, Any]]
    flown: int  # runs flown now (not taken from an earlier table)
    skipped: int  # runs already in the table (--resume)
    #: runs in the table flown with other settings under the same key (--resume flew them again)
    changed: int
    stopped: bool  # a signal ended it before every run was flown
    wall_s: float


def hand_out_order(task: RunTask) -> tuple[Any, ...]:
    """The order runs are handed to the workers: the largest first, so that no worker is left with
    a long run at the end; among equals, runs that can share a simulator one after another (a
    worker keeps a few: quadsim.apps.sweep.run). The table keeps the sweep's own order."""
    run = task.run
    return (-run.sim_s, run.airframe, run.controller.name, run.wind, run.turbulence, run.scenario, run.index)


def _table(
    spec: SweepSpec, out: Path, resume: bool, overwrite: bool, table_format: str | None
) -> tuple[Path, dict[int, dict[str, Any]], int]:
    """The table's path in `out`, the rows of an earlier table kept for --resume (by index), each
    judged against the sweep file's limits as they are now, and how many rows under the same key
    were flown with other settings (flown again); an existing table is replaced only with
    --overwrite."""
    check_table_free(out, resume, overwrite)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise QuadsimError(f"cannot create the sweep folder {out}: {exc.strerror}") from None
    previous = existing_table(out)
    if previous is not None and overwrite:  # asked for: the old table goes, every run flies again
        previous.unlink()
        previous = None
    rows: dict[int, dict[str, Any]] = {}
    if previous is None:
        return table_path(out, table_format), rows, 0
    runs = {run.key: run for run in spec.runs}
    limits = tuple(sorted(spec.limits.items()))
    changed = 0
    for row in read_table(previous):
        run = runs.get(row.get("key"))  # type: ignore[arg-type]
        if run is None or row.get("status") not in ("ok", "fail"):  # a run that could not fly is retried
            continue
        if row.get("settings") != run.settings:  # the scenario, gains or duration changed since
            changed += 1
            continue
        rows[run.index] = judge({**row, "index": run.index}, limits)
    return previous, rows, changed


def run_sweep(
    spec: SweepSpec,
    out: Path,
    jobs: int = 1,
    use_ray: bool = False,
    ray_address: str | None = None,
    record: str | None = None,
    resume: bool = False,
    table_format: str | None = None,
    overwrite: bool = False,
    progress: bool = True,
) -> SweepResult:
    """Fly the runs of `spec` not yet in the table in `out` (every run, unless --resume), saving
    the table as runs come in and once more on any exit, so that nothing flown is lost."""
    path, rows, changed = _table(spec, out, resume, overwrite, table_format)
    todo = [
        RunTask(run, tuple(sorted(spec.limits.items())), record, str(out / "recordings") if record else None)
        for run in spec.runs
        if run.index not in rows
    ]
    todo.sort(key=hand_out_order)
    for task in todo:  # a run flown again replaces its own recording, or leaves none to mislead check
        recording_path(out / "recordings", task.run).unlink(missing_ok=True)
    skipped = len(rows)
    bar = ProgressBar(len(spec.runs), "sweep", unit="runs") if progress else None
    eta = Eta(len(todo))
    t0 = time.monotonic()
    last_save = t0
    flown = 0
    try:
        for row in run_tasks(fly_run, todo, jobs, ray_address, use_ray):
            rows[row["index"]] = row
            flown += 1
            if bar is not None:
                bar.update(skipped + flown, eta.text(flown))
            if time.monotonic() - last_save > _SAVE_EVERY_S:
                # a table that cannot be written (a broken pyarrow, a full disk) is said by the
                # last write, below, once every run is flown: a save on the way stops none of them
                with shielded_from_signals(), contextlib.suppress(QuadsimError, OSError):
                    write_table(path, rows.values())
                last_save = time.monotonic()
    finally:
        with shielded_from_signals():  # what was flown is never lost
            write_table(path, rows.values())
        if bar is not None:
            bar.close()
        forget_simulators()  # those kept by runs flown in this process (--jobs 1)
    return SweepResult(
        path,
        sorted(rows.values(), key=lambda r: r["index"]),
        flown,
        skipped,
        changed,
        stop_requested() and len(rows) < len(spec.runs),
        time.monotonic() - t0,
    )


def check_table_free(out: Path, resume: bool, overwrite: bool) -> None:
    """Refuse, before anything is said or flown, a folder whose table would be overwritten unasked."""
    previous = existing_table(out) if out.is_dir() else None
    if previous is not None and not resume and not overwrite:
        raise QuadsimError(
            f"{previous} already exists: add --resume to fly only the runs missing from it, "
            f"--overwrite to fly them all again, or choose another --out (nothing is overwritten unasked)"
        )
