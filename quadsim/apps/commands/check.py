"""`quadsim check`: re-fly recordings as regression tests; exit 1 when one changed, 2 when one
cannot be used. The pytest plugin runs the same implementation (quadsim.apps.regression)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from quadsim.apps.commands import add_command_parser
from quadsim.apps.options import add_parallel_options, number
from quadsim.apps.regression import (
    DEFAULT_TOLERANCE_M,
    DEFAULT_TOLERANCE_RAD,
    CheckOutcome,
    CheckTask,
    check_one,
    recordings_in,
)
from quadsim.apps.sweep.backends import default_jobs, ray_available, ray_missing, run_tasks
from quadsim.errors import QuadsimError
from quadsim.session.stopping import SignalStop
from quadsim.session.stopping import exit_code as stop_exit_code


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command_parser(
        sub,
        "check",
        description="Fly each recording's commands again and compare with what it recorded. Exit code "
        "0 when every recording re-flies within the tolerances, 1 when one no longer does "
        "(with a report: which topic, when, how far), 2 when a file cannot be used. A recording re-flies "
        "with the vehicle, world and gains it recorded: it tests a change to the code, and a note says when "
        "the vehicle's parameter or gains file has changed since (record the flight again to test that).",
    )
    p.add_argument("paths", type=Path, nargs="+", metavar="DIR|FILE", help="recordings, or folders of them")
    p.add_argument(
        "--tolerance-m",
        type=number(0.0, 1e6, "metres"),
        default=DEFAULT_TOLERANCE_M,
        help=f"position tolerance (default {DEFAULT_TOLERANCE_M:g} m)",
    )
    p.add_argument(
        "--tolerance-rad",
        type=number(0.0, math.pi, "radians"),
        default=DEFAULT_TOLERANCE_RAD,
        help=f"attitude tolerance (default {DEFAULT_TOLERANCE_RAD:g} rad)",
    )
    add_parallel_options(
        p, "re-fly N recordings at once in worker processes (default 1; the report stays in file order)"
    )


def main(args: argparse.Namespace) -> int:

    files = recordings_in(args.paths)
    jobs = args.jobs if args.jobs is not None else 1
    if not 1 <= jobs <= 1024:
        raise QuadsimError(f"--jobs must be from 1 to 1024, got {jobs}")
    use_ray = args.ray is not None
    if use_ray and not ray_available():
        raise QuadsimError(ray_missing())
    tasks = [CheckTask(path, args.tolerance_m, args.tolerance_rad) for path in files]
    if use_ray and args.jobs is None:
        jobs = default_jobs()
    if len(files) > 1:  # each takes seconds: say what comes before the first line does
        at_once = f", {jobs} at a time" if jobs > 1 else ", one after the other"
        print(
            f"quadsim: re-flying {len(files)} recordings{at_once}; each is reported as it is done",
            file=sys.stderr,
            flush=True,
        )
    # results come in completion order; the report keeps the order of the files
    outcomes: dict[Path, CheckOutcome] = {}
    shown = 0
    for outcome in run_tasks(check_one, tasks, jobs, None if args.ray in (None, "local") else args.ray, use_ray):
        outcomes[outcome.path] = outcome
        while shown < len(files) and files[shown] in outcomes:
            for line in outcomes[files[shown]].lines:
                print(line, flush=True)
            shown += 1
    failed = sum(o.status == "changed" for o in outcomes.values())
    folders = {f for f in files if f.is_dir()}  # named, with no recording in them
    empty = sum(o.status == "unusable" and o.path in folders for o in outcomes.values())
    unusable = sum(o.status == "unusable" for o in outcomes.values()) - empty
    total = len(files) - len(folders)
    not_checked = len(files) - len(outcomes)
    print(
        f"{total - failed - unusable - not_checked} of {total} recordings re-fly within {args.tolerance_m:g} m and "
        f"{args.tolerance_rad:g} rad"
        + (f"; {failed} changed" if failed else "")
        + (f"; {unusable} unusable" if unusable else "")
        + (f"; {not_checked} not checked (stopped)" if not_checked else "")
        + (f"; {empty} folder{'s' * (empty != 1)} with no recording" if empty else "")
    )
    unusable += empty  # a folder named that holds nothing is a mistake: exit 2, as for an unusable file
    if unusable or failed:
        return 2 if unusable else 1
    stop = SignalStop.current()
    if not_checked and stop is not None and stop.signum is not None:
        return stop_exit_code(stop.signum)  # stopped before the end: 130/143, as the line above says
    return 0
