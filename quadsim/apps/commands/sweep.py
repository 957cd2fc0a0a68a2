"""`quadsim sweep SPEC.toml`: fly every run a sweep file stands for and tabulate their flight metrics."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from quadsim.apps.commands import add_command_parser
from quadsim.apps.options import add_parallel_options, recordings_default, stopped_by_signal
from quadsim.apps.sweep.backends import default_jobs, ray_available, ray_missing
from quadsim.apps.sweep.execute import check_table_free, run_sweep
from quadsim.apps.sweep.report import plot, summary_lines
from quadsim.apps.sweep.spec import load_sweep
from quadsim.apps.sweep.table import parquet_available
from quadsim.core import compiled  # here: numba's import is not every command's
from quadsim.core.invocation import install_extra
from quadsim.errors import QuadsimError
from quadsim.recording.paths import default_recordings_dir

if TYPE_CHECKING:
    from quadsim.apps.sweep.execute import SweepResult
    from quadsim.apps.sweep.spec import SweepSpec

#: past this many runs or this much simulated time, `sweep` asks for --yes before flying
ASK_RUNS = 1_000
ASK_SIM_S = 24 * 3600.0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command_parser(
        sub,
        "sweep",
        description="Fly the runs a sweep file stands for (a TOML file of scenarios, airframes, controllers, wind, "
        "turbulence, seeds and [limits]; a scenario may be a fleet file, whose row is its worst vehicle's), "
        "each a headless run measured with flight metrics, on a pool of processes (--jobs) or on Ray (--ray). Results go "
        "to one table (results.parquet with pyarrow installed, else results.csv) in --out, with a summary "
        "printed (mean and worst per group) and a plot (plot.png, with matplotlib). The same sweep file "
        "gives the same table whatever runs it. Ctrl-C stops cleanly and keeps the runs flown; --resume "
        "flies only the runs missing from the table. Exit code 0 when every run is within the file's "
        "[limits], 1 when one is not or could not fly, 2 on a bad sweep file.",
    )
    p.add_argument("spec", type=Path, metavar="SPEC.toml", help="the sweep file")
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="DIR",
        help=f"where the table, plot and recordings go (default: {recordings_default('sweeps/NAME')})",
    )
    add_parallel_options(
        p, "worker processes (default: every core of this machine); with --ray, CPUs of a local Ray instance"
    )
    rec = p.add_mutually_exclusive_group()
    rec.add_argument("--record", action="store_true", help="keep an MCAP recording of every run")
    rec.add_argument("--record-failures", action="store_true", help="keep recordings of runs beyond the limits only")
    again = p.add_mutually_exclusive_group()
    again.add_argument("--resume", action="store_true", help="fly only the runs missing from the table in --out")
    again.add_argument("--overwrite", action="store_true", help="replace the table in --out: fly every run again")
    p.add_argument(
        "--format",
        choices=["parquet", "csv"],
        default=None,
        help="table format (default: parquet when pyarrow is installed, else csv)",
    )
    p.add_argument("--no-plot", action="store_true", help="do not draw plot.png")
    p.add_argument(
        "--yes",
        action="store_true",
        help=f"fly a very large sweep (over {ASK_RUNS} runs or {ASK_SIM_S / 3600:.0f} h of simulated time) "
        "without asking for this flag first",
    )


def main(args: argparse.Namespace) -> int:

    spec = load_sweep(args.spec)
    if (len(spec.runs) > ASK_RUNS or spec.sim_s > ASK_SIM_S) and not args.yes:
        raise QuadsimError(
            f"{args.spec}: {len(spec.runs)} runs, {spec.sim_s / 3600:.1f} h of simulated flight: "
            "add --yes to fly a sweep this large"
        )
    jobs = args.jobs if args.jobs is not None else default_jobs()
    _check_where(args, jobs)
    out = args.out if args.out is not None else default_recordings_dir() / "sweeps" / spec.name
    if out.exists() and not out.is_dir():
        raise QuadsimError(f"--out {out} is a file: a sweep's results go in a folder")
    use_ray = args.ray is not None
    if not use_ray:  # a worker beyond one per run would only start and stop (--jobs 1000: 654 processes)
        jobs = min(jobs, len(spec.runs))
    where = (
        f"Ray ({'local, ' + str(jobs) + ' CPUs' if args.ray == 'local' else args.ray})"
        if use_ray
        else (f"{jobs} worker process{'es' if jobs > 1 else ''}")
    )
    check_table_free(out, args.resume, args.overwrite)  # said before the sweep's first line
    print(
        f"sweep '{spec.name}': {len(spec.runs)} run{'s' * (len(spec.runs) != 1)} on {where}; results in {out}",
        flush=True,
    )

    # the runs fly as plain Python: say how to have them faster when that clearly pays for the
    # time the compiled core costs each worker to load (about a quarter of a second a forked
    # worker, half a second a spawned one: it breaks even at about 3 or 6 minutes of flight a worker)
    if not compiled.COMPILED and spec.sim_s > 600.0 * jobs:
        print(f"note: {compiled.status()}", flush=True)
    result = run_sweep(
        spec,
        out,
        jobs=jobs,
        use_ray=use_ray,
        ray_address=None if args.ray in (None, "local") else args.ray,
        record="all" if args.record else "failures" if args.record_failures else None,
        resume=args.resume,
        table_format=args.format,
        overwrite=args.overwrite,
    )
    return _report(args, spec, result, out)


def _check_where(args: argparse.Namespace, jobs: int) -> None:
    """The workers and the table format asked for exist, before any run flies."""

    if not 1 <= jobs <= 1024:
        raise QuadsimError(f"--jobs must be from 1 to 1024, got {jobs}")
    if args.ray is not None and not ray_available():
        raise QuadsimError(ray_missing())
    if args.format == "parquet" and not parquet_available():
        raise QuadsimError(f"--format parquet needs pyarrow: {install_extra('parquet')}")


def _report(args: argparse.Namespace, spec: SweepSpec, result: SweepResult, out: Path) -> int:
    """The summary, the table and the plot; the exit code (0 all within limits, 1 not, 130/143 stopped)."""

    for line in summary_lines(result.rows, [a for a in spec.varied]):
        print(line)
    kept = [f"{result.skipped} already in the table"] if result.skipped else []
    if result.changed:
        kept.append(f"{result.changed} flown again: their scenario, gains or duration changed since")
    skipped = "".join(f"; {k}" for k in kept)
    print(f"table           {result.table} ({len(result.rows)} of {len(spec.runs)} runs{skipped})")
    if not args.no_plot and result.rows:
        try:
            png = plot(result.rows, spec.varied, out / "plot.png", f"sweep '{spec.name}'")
            if png is not None:
                print(f"plot            {png}")
            elif all(r["status"] == "error" for r in result.rows):
                print("plot            none: no run flew")
            else:
                print("plot            none: every metric is 0 in every run")
        except ImportError:
            print(f"plot            skipped: matplotlib is not installed: {install_extra('plot')}")
    if result.stopped:  # by a signal: said, with what --resume would fly
        left = len(spec.runs) - len(result.rows)
        code = stopped_by_signal(
            f" after {result.flown} run{'s' * (result.flown != 1)}; --resume flies the {left} left"
        )
        if code is not None:
            return code
    return 0 if all(r["status"] == "ok" for r in result.rows) else 1
