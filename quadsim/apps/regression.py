"""Recordings as regression tests: one recording re-flown and judged against tolerances, the
implementation `quadsim check` and the pytest plugin share (in the same order, with the same report
and exit codes, serial, on a process pool or on Ray)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from quadsim.errors import QuadsimError

if TYPE_CHECKING:
    from quadsim.session.fleet_resim import FleetResimReport

#: how far a re-flight may stray from its recording, by default (`check`, the pytest plugin)
DEFAULT_TOLERANCE_M = 1e-3
DEFAULT_TOLERANCE_RAD = 1e-3


@dataclass(frozen=True)
class CheckTask:
    path: Path
    tolerance_m: float
    tolerance_rad: float


@dataclass(frozen=True)
class CheckOutcome:
    path: Path
    status: str  # "ok", "changed" or "unusable"
    lines: tuple[str, ...]


def recordings_in(paths: list[Path]) -> list[Path]:
    """The files named, and the .mcap files under the folders named (an empty folder stays, to be
    reported as unusable)."""
    files: list[Path] = []
    for path in paths:
        if path.is_dir():
            files += sorted(path.rglob("*.mcap")) or [path]
        else:
            files.append(path)
    return files


def check_one(task: CheckTask) -> CheckOutcome:
    """Re-fly one recording (one vehicle's or a fleet's) and say how it went (never raises for a
    bad file: it is 'unusable')."""
    from quadsim.recording.flight import load_flights
    from quadsim.session.fleet_resim import resimulate_fleet
    from quadsim.session.resim import NothingFlown, ResimReport, resimulate

    path = task.path
    try:
        if path.is_dir():
            raise QuadsimError("no .mcap recordings in this folder")
        flights = load_flights(path)
        flight = next(iter(flights.values()))
        m, rad = task.tolerance_m, task.tolerance_rad
        if flight.vehicle:
            report: ResimReport | FleetResimReport = resimulate_fleet(
                flights, record=False, position_tolerance_m=m, attitude_tolerance_rad=rad
            )
        else:
            report = resimulate(flight, record=False, position_tolerance_m=m, attitude_tolerance_rad=rad)
    except NothingFlown:  # a run stopped at once: its (empty) flight is the same as re-flown
        return CheckOutcome(path, "ok", (f"ok    {path}: nothing was flown (stopped before the first step)",))
    except QuadsimError as exc:
        return CheckOutcome(path, "unusable", (f"ERROR {path}: {str(exc).removeprefix(f'{path}: ')}",))
    ok = report.within(task.tolerance_m, task.tolerance_rad)
    if isinstance(report, ResimReport):
        position, attitude, what = report.position.max_error, report.attitude.max_error, ""
    else:
        position, attitude = report.worst_position_m, report.worst_attitude_rad
        what = f" (a fleet of {len(report.vehicles)})"
    lines = [
        f"{'ok   ' if ok else 'FAIL '} {path}{what}: position off by up to {position:.3g} m, "
        f"attitude by up to {attitude:.3g} rad"
    ]
    if not ok:
        lines += ["     " + line for line in report.lines()[1:]]
    lines += [f"      note: {line}" for line in flight.warnings()]
    return CheckOutcome(path, "ok" if ok else "changed", tuple(lines))
