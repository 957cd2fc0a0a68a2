"""One run of a sweep: a pure function of its RunSpec (same spec, same row, on any machine and in
any worker), so a pool, Ray or a resumed sweep all give the same table."""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from quadsim.apps.sweep.metrics import METRICS, flight_metrics
from quadsim.apps.sweep.spec import RunSpec
from quadsim.core.types import ZMode

if TYPE_CHECKING:
    from quadsim.drivers import InputDriver
    from quadsim.sim.config import SimConfig
    from quadsim.sim.simulator import Simulator

#: "ok": within limits; "fail": a metric beyond its limit; "error": the run could not fly
STATUSES = ("ok", "fail", "error")


@dataclass(frozen=True)
class RunTask:
    """A run and what to do with its recording: None (no recording), "all" or "failures"."""

    run: RunSpec
    limits: tuple[tuple[str, float], ...] = ()
    record: str | None = None
    record_dir: str | None = None


#: simulators a worker keeps between runs (each holds a PyBullet world: a few MB)
MAX_KEPT = 4
_kept: OrderedDict[tuple[Any, ...], Simulator] = OrderedDict()


def _config(run: RunSpec, z_mode: ZMode | None) -> SimConfig:
    from quadsim.physics.wind import wind_from_text
    from quadsim.sim.config import SimConfig
    from quadsim.vehicle.params import SHIPPED_VEHICLES

    return SimConfig(
        urdf=SHIPPED_VEHICLES[run.airframe],
        controller=run.controller.kind,
        z_mode=z_mode,
        wind=wind_from_text(run.wind, run.turbulence),
        seed=run.seed,
    )


def _simulator(run: RunSpec, config: SimConfig, driver: InputDriver) -> Simulator:
    """A simulator for `run`: one this worker built for an earlier run with the same airframe,
    controller, gains, wind and z-mode, restarted with this run's seed and driver (it flies bit
    for bit as a new one would: tests/test_sweep.py checks), else a new one. The world and the
    vehicle are loaded once per worker, not once per run."""
    from quadsim.sim.simulator import Simulator

    key = (run.airframe, run.controller, run.wind, run.turbulence, config.z_mode)
    sim = _kept.pop(key, None)
    if sim is None:
        sim = Simulator(config, driver, controller_gains=dict(run.controller.gains) or None)
    else:
        sim.restart(driver, seed=run.seed)
    _kept[key] = sim
    while len(_kept) > MAX_KEPT:
        _kept.popitem(last=False)[1].close()
    return sim


def forget_simulators() -> None:
    """Close the simulators this process keeps between runs."""
    while _kept:
        _kept.popitem()[1].close()


def fly_run(task: RunTask) -> dict[str, Any]:
    """Fly one run headless and return its table row (never raises for a run that cannot fly:
    the row says why)."""
    run = task.run
    row: dict[str, Any] = {"index": run.index, "key": run.key, "settings": run.settings, **run.axes()}
    row.update(dict.fromkeys(METRICS, math.nan))
    row.update(status="error", failed_limits="", error="", recording="")
    try:
        fly = _fly_fleet if run.is_fleet else _fly_script
        metrics, failed, recorded = fly(task)
        row.update(metrics)
        row["status"] = "fail" if failed else "ok"
        row["failed_limits"] = ",".join(failed)
        if recorded is not None and recorded.path is not None:
            if task.record == "failures" and not failed:
                recorded.path.unlink(missing_ok=True)
            else:
                row["recording"] = str(recorded.path)
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


def _fly_script(task: RunTask) -> tuple[dict[str, float], list[str], Any]:
    """A scenario's run on this worker's kept simulator: its metrics, the limits it broke, its recording."""
    from quadsim.drivers.scripted import ScriptedDriver, load_script
    from quadsim.sim.loop import StateLog

    run = task.run
    script = load_script(run.scenario)
    duration = run.duration_s if run.duration_s is not None else script.duration_s
    config = _config(run, script.z_mode or ZMode.VELOCITY)
    try:
        sim = _simulator(run, config, ScriptedDriver(script))
        log = StateLog()
        sim.add_sink(log)
        recorded = _start_recording(task, sim, script.name) if task.record else None
        try:
            sim.run_for(duration)
        finally:
            sim.remove_sink(log)
            if recorded is not None:
                recorded.close()
    except BaseException:
        forget_simulators()  # a run that failed half-way leaves nothing behind to reuse
        raise
    metrics = flight_metrics(log.states, log.commands, config.rates.physics_hz, sim.events)
    return metrics, _beyond(task.limits, metrics), recorded


def _fly_fleet(task: RunTask) -> tuple[dict[str, float], list[str], Any]:
    """A fleet file's run: every vehicle flown in one world; each metric the largest over the
    vehicles, and each broken limit named with the vehicle that broke it worst."""
    from quadsim.apps.fleet_flight import fleet_drivers
    from quadsim.sim.fleet import Fleet
    from quadsim.sim.fleet_file import load_fleet_file
    from quadsim.sim.loop import StateLog

    run = task.run
    fleet_file = load_fleet_file(Path(run.scenario))
    duration = run.duration_s if run.duration_s is not None else run.sim_s
    config = _config(run, None)  # each vehicle's z-mode its own (its file's, else its script's)
    with Fleet(fleet_file.fleet_vehicles(fleet_drivers(fleet_file)), config) as fleet:
        logs = {name: StateLog() for name in fleet}
        for name, log in logs.items():
            fleet[name].add_sink(log)
        recorded = _start_fleet_recording(task, fleet, fleet_file.path.name) if task.record else None
        try:
            fleet.run_for(duration)
        finally:
            if recorded is not None:
                recorded.close()
        each = {
            name: flight_metrics(log.states, log.commands, config.rates.physics_hz, fleet[name].events)
            for name, log in logs.items()
        }
    metrics: dict[str, float] = {}
    worst: dict[str, str] = {}
    for name in METRICS:
        known = [(m[name], vehicle) for vehicle, m in each.items() if not math.isnan(m.get(name, math.nan))]
        metrics[name], worst[name] = max(known) if known else (math.nan, "")
    return metrics, [f"{name} ({worst[name]})" for name in _beyond(task.limits, metrics)], recorded


def recording_path(folder: Path, run: RunSpec) -> Path:
    """Where a run's recording goes in the sweep's recordings folder (its index and values)."""
    name = f"{run.index:05d}_" + "_".join(str(v) for v in run.axes().values())
    return folder / f"{_safe(name)}.mcap"


def _recording_options(task: RunTask) -> Any:
    from quadsim.session.outputs import OutputOptions

    return OutputOptions(record=True, out=recording_path(Path(task.record_dir or "."), task.run), cameras=())


def _start_recording(task: RunTask, sim: Any, script_name: str):
    from quadsim.session.outputs import RecordedRun

    info = {"command": "sweep", "script": script_name, "key": task.run.key}
    return RecordedRun(sim, sim.description(), _recording_options(task), f"sweep_{task.run.index}", info)


def _start_fleet_recording(task: RunTask, fleet: Any, fleet_name: str):
    from quadsim.session.fleet_outputs import FleetRecordedRun

    info = {"command": "sweep", "fleet": fleet_name, "key": task.run.key}
    return FleetRecordedRun(fleet, _recording_options(task), f"sweep_{task.run.index}", info)


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "._-" else "-" for c in name)[:200]
