"""Recordings as regression tests: one recording re-flown and judged against tolerances, the
implementation `quadsim check` and the pytest plugin share (in the same order, with the same report
and exit codes, serial, on a process pool or on Ray)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from quadsim.errors import QuadsimError

if TYPE_CHECKING:
    from quadsim.sim.description import RunDescription

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
    """The files named, and the .mcap files under the folders named, each once, in the order
    named (an empty folder stays, to be reported as unusable)."""
    files: dict[Path, Path] = {}  # by where it is: a file named twice (a folder and a file in it) once
    for path in paths:
        for f in (sorted(path.rglob("*.mcap")) or [path]) if path.is_dir() else [path]:
            files.setdefault(f.resolve(), f)
    return list(files.values())


def check_one(task: CheckTask) -> CheckOutcome:
    """Re-fly one recording (one vehicle's or a fleet's) and say how it went (never raises for a
    bad file: it is 'unusable')."""
    from quadsim.recording.flight import load_flights
    from quadsim.session.resim import NothingFlown, resimulate

    path = task.path
    try:
        if path.is_dir():
            raise QuadsimError("no .mcap recordings in this folder")
        flights = load_flights(path)
        flight = next(iter(flights.values()))
        m, rad = task.tolerance_m, task.tolerance_rad
        report = resimulate(flights, record=False, position_tolerance_m=m, attitude_tolerance_rad=rad)
    except NothingFlown:  # a run stopped at once: its (empty) flight is the same as re-flown
        return CheckOutcome(path, "ok", (f"ok    {path}: nothing was flown (stopped before the first step)",))
    except QuadsimError as exc:
        return CheckOutcome(path, "unusable", (f"ERROR {path}: {str(exc).removeprefix(f'{path}: ')}",))
    ok = report.within(task.tolerance_m, task.tolerance_rad)
    position, attitude = report.position.max_error, report.attitude.max_error
    what = f" (a fleet of {report.fleet_size})" if report.fleet_size else ""
    if position == 0.0 and attitude == 0.0:  # bit for bit: said as such, not as an error of 0
        how = "flies again identically (position and attitude as recorded, to the bit)"
        if report.readings_identical:
            how += ", and its range finder and LiDAR read the same"
    else:
        how = f"position off by up to {position:.3g} m, attitude by up to {attitude:.3g} rad"
    lines = [f"{'ok   ' if ok else 'FAIL '} {path}{what}: {how}"]
    if not ok:
        lines += ["     " + line for line in report.lines()[1:]]
    lines += [f"      note: {line}" for line in flight.warnings()]
    for name, each in flights.items():
        if each.description is not None:
            changed = files_changed_since(each.description)
            lines += [f"      note: {name + ': ' if name else ''}{line}" for line in changed]
    return CheckOutcome(path, "ok" if ok else "changed", tuple(lines))


def files_changed_since(description: RunDescription) -> list[str]:
    """What differs between the vehicle parameter and gains files a recording flew with (it keeps
    them, and re-flies with them) and the same files today: a re-flight within tolerance does not
    test a change to them, so it is said (nothing when the files are gone or are another vehicle's)."""
    import json
    from dataclasses import asdict

    from quadsim.control import gains_type
    from quadsim.control.gains import gains_path, load_gains
    from quadsim.vehicle.params import load_vehicle

    cfg = description.config
    tail = "it re-flies with its own, so this check does not test the file's (a flight recorded again does)"
    if any(p is not None and not Path(p).is_file() for p in (cfg.urdf, cfg.vehicle_params)):
        return []  # flown on another machine, or the files were moved: nothing to compare with
    kind = description.controller.kind
    try:
        vehicle = load_vehicle(cfg.urdf, cfg.vehicle_params)
        # a controller of the user's own has no gains file: its parameters are its own business
        gains = asdict(load_gains(vehicle, kind.value, gains_type(kind))) if kind is not None else {}
    except QuadsimError as exc:
        return [f"the vehicle's files as they are now cannot be flown ({exc}): {tail}"]
    if vehicle.name != description.vehicle.name:
        return []
    now = json.loads(json.dumps(vehicle.to_dict()))  # as a recording holds it (lists, not tuples)
    recorded = description.vehicle.details
    notes = []
    params = sorted(k for k in (now.keys() | recorded.keys()) - {"urdf", "params"} if now.get(k) != recorded.get(k))
    if params:
        notes.append(
            f"this recording's vehicle differs from {vehicle.params_path.name} (or its URDF) as it is now, in "
            f"{', '.join(params[:4])}{', ...' if len(params) > 4 else ''}: {tail}"
        )
    changed = [g for g in sorted(gains) if gains[g] != description.controller.gains.get(g)]
    if changed:
        shown = ", ".join(
            f"{g} {description.controller.gains.get(g)!r:.12} recorded, {gains[g]!r:.12} in the file"
            for g in changed[:3]
        )
        notes.append(
            f"this recording's {description.controller.name} gains differ from {gains_path(vehicle).name} as it is now "
            f"({shown}{', ...' if len(changed) > 3 else ''}): {tail}"
        )
    return notes
