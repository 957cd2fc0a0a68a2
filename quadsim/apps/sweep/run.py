"""One run of a sweep: a pure function of its RunSpec (same spec, same row, on any machine and in
any worker), so a pool, Ray or a resumed sweep all give the same table."""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from quadsim.apps.plans import fleet_drivers
from quadsim.apps.sweep.metrics import METRICS, flight_metrics
from quadsim.apps.sweep.spec import RunSpec
from quadsim.core.types import ZMode
from quadsim.drivers.scripted import ScriptedDriver, load_script
from quadsim.physics.wind import wind_from_text
from quadsim.session.outputs import OutputOptions
from quadsim.session.plan import RunPlan
from quadsim.session.run import Run, to_the_end
from quadsim.sim.config import SimConfig
from quadsim.sim.fleet import Fleet
from quadsim.sim.fleet_file import load_fleet_file
from quadsim.sim.loop import StateLog
from quadsim.vehicle.params import SHIPPED_VEHICLES


@dataclass(frozen=True)
class RunTask:
    """A run and what to do with its recording: None (no recording), "all" or "failures"."""

    run: RunSpec
    limits: tuple[tuple[str, float], ...] = ()
    record: str | None = None
    record_dir: str | None = None


#: fleets (a run of one vehicle is a fleet of one) a worker keeps between runs (each holds a
#: PyBullet world: a few MB)
MAX_KEPT = 4
_kept: OrderedDict[tuple[Any, ...], Fleet] = OrderedDict()


def _config(run: RunSpec, z_mode: ZMode | None) -> SimConfig:
    return SimConfig(
        urdf=SHIPPED_VEHICLES[run.airframe],
        controller=run.controller.kind,
        z_mode=z_mode,
        wind=wind_from_text(run.wind, run.turbulence),
        seed=run.seed,
    )


def plan_of(task: RunTask) -> RunPlan:
    """The run as a plan: a scenario's script flown by the run's airframe and controller, or a
    fleet file's vehicles (each with its own), in the run's wind and seed; recorded as asked."""
    run = task.run
    outputs = OutputOptions(record=bool(task.record), out=recording_path(Path(task.record_dir or "."), run), cameras=())
    if run.is_fleet:
        fleet_file = load_fleet_file(Path(run.scenario))
        info = {"command": "sweep", "fleet": fleet_file.path.name, "key": run.key}
        return RunPlan(
            _config(run, None),  # each vehicle's z-mode its own (its file's, else its script's)
            tuple(fleet_file.fleet_vehicles(fleet_drivers(fleet_file))),
            duration_s=run.duration_s if run.duration_s is not None else run.sim_s,
            outputs=outputs,
            label=f"sweep_{run.index}",
            run_info=info,
        )
    script = load_script(run.scenario)
    return RunPlan.alone(
        _config(run, script.z_mode or ZMode.VELOCITY),
        ScriptedDriver(script),
        dict(run.controller.gains) or None,
        duration_s=run.duration_s if run.duration_s is not None else script.duration_s,
        outputs=outputs,
        label=f"sweep_{run.index}",
        run_info={"command": "sweep", "script": script.name, "key": run.key},
    )


def _fleet(plan: RunPlan) -> Fleet:
    """The plan's fleet: one this worker built for an earlier run with the same vehicles, settings
    and z-modes (all but the seed and the drivers), restarted with this run's seed and drivers
    (it flies bit for bit as a new one would: tests/e2e/test_sweep.py checks), else a new one. The
    world and the vehicles are loaded once per worker, not once per run."""
    key = (
        replace(plan.config, seed=0),
        tuple(
            (v.name, v.start, v.urdf, v.vehicle_params, v.controller, v.z_mode, repr(v.controller_gains))
            for v in plan.vehicles
        ),
    )
    fleet = _kept.pop(key, None)
    if fleet is None:
        fleet = Fleet(plan.vehicles, plan.config, plan.landing, plan.reset_on_crash)
    else:
        fleet.restart({name: driver for name, driver in plan.drivers.items() if driver is not None}, plan.config.seed)
    _kept[key] = fleet
    while len(_kept) > MAX_KEPT:
        _kept.popitem(last=False)[1].close()
    return fleet


def forget_simulators() -> None:
    """Close the fleets this process keeps between runs."""
    while _kept:
        _kept.popitem()[1].close()


def fly_run(task: RunTask) -> dict[str, Any]:
    """Fly one run headless and return its table row, whose status is "ok" (within limits), "fail"
    (a metric beyond its limit) or "error" (never raised for a run that cannot fly: the row says
    why)."""
    run = task.run
    row: dict[str, Any] = {"index": run.index, "key": run.key, "settings": run.settings, **run.axes()}
    row.update(dict.fromkeys(METRICS, math.nan))
    row.update(status="error", failed_limits="", error="", recording="")
    try:
        metrics, failed, recorded = _fly(task)
        row.update(metrics)
        row["status"] = "fail" if failed else "ok"
        row["failed_limits"] = ",".join(failed)
        if recorded is not None:
            if task.record == "failures" and not failed:
                recorded.unlink(missing_ok=True)
            else:
                row["recording"] = str(recorded)
    except Exception as exc:  # one bad run must not end the sweep: its row says what happened
        row["status"] = "error"
        row["error"] = f"{type(exc).__name__}: {exc}"
    return row


def _beyond(limits: tuple[tuple[str, float], ...], metrics: dict[str, float]) -> list[str]:
    return [name for name, limit in limits if not math.isnan(metrics.get(name, math.nan)) and metrics[name] > limit]


def judge(row: dict[str, Any], limits: tuple[tuple[str, float], ...]) -> dict[str, Any]:
    """A row flown earlier, judged against today's limits (`--resume` after the sweep file's
    [limits] changed kept yesterday's verdicts); a fleet's limit keeps the vehicle that broke it."""
    metrics = {name: row[name] for name in METRICS if isinstance(row.get(name), float)}
    named = {entry.split(" (")[0]: entry for entry in str(row.get("failed_limits") or "").split(",") if entry}
    failed = [named.get(name, name) for name in _beyond(limits, metrics)]
    return {**row, "status": "fail" if failed else "ok", "failed_limits": ",".join(failed)}


def _fly(task: RunTask) -> tuple[dict[str, float], list[str], Path | None]:
    """The run flown on this worker's kept fleet: its metrics (each the largest over the vehicles
    of a fleet), the limits it broke (a fleet's named with the vehicle that broke it worst) and
    its recording."""
    plan = plan_of(task)
    try:
        fleet = _fleet(plan)
        logs = {name: StateLog() for name in fleet}
        for name, log in logs.items():
            fleet[name].add_sink(log)
        try:
            with Run(plan, fleet) as run:
                run.fly(stop=to_the_end)
                recorded = run.outputs.path
        finally:
            for name, log in logs.items():
                fleet[name].remove_sink(log)
    except BaseException:
        forget_simulators()  # a run that failed half-way leaves nothing behind to reuse
        raise
    hz = plan.config.rates.physics_hz
    each = {name: flight_metrics(log.states, log.commands, hz, fleet[name].events) for name, log in logs.items()}
    metrics: dict[str, float] = {}
    worst: dict[str, str] = {}
    for name in METRICS:
        known = [(m[name], vehicle) for vehicle, m in each.items() if not math.isnan(m.get(name, math.nan))]
        metrics[name], worst[name] = max(known) if known else (math.nan, "")
    failed = [f"{name} ({worst[name]})" if worst[name] else name for name in _beyond(task.limits, metrics)]
    return metrics, failed, recorded


def recording_path(folder: Path, run: RunSpec) -> Path:
    """Where a run's recording goes in the sweep's recordings folder (its index and values)."""
    name = f"{run.index:05d}_" + "_".join(str(v) for v in run.axes().values())
    return folder / f"{_safe(name)}.mcap"


def _safe(name: str) -> str:
    return "".join(c if (c.isascii() and c.isalnum()) or c in "._-" else "-" for c in name)[:200]  # bytes, too
