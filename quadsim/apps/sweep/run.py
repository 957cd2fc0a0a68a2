"""One run of a sweep: a pure function of its RunSpec (same spec, same row, on any machine and in
any worker), so a pool, Ray or a resumed sweep all give the same table."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from quadsim.apps.sweep.metrics import METRICS, flight_metrics
from quadsim.apps.sweep.spec import RunSpec

#: what a run reports besides its axes and metrics
STATUS_COLUMNS = ("index", "key", "status", "failed_limits", "error", "recording")
#: "ok": within limits; "fail": a metric beyond its limit; "error": the run could not fly
STATUSES = ("ok", "fail", "error")


@dataclass(frozen=True)
class RunTask:
    """A run and what to do with its recording: None (no recording), "all" or "failures"."""

    run: RunSpec
    limits: tuple[tuple[str, float], ...] = ()
    record: str | None = None
    record_dir: str | None = None


def _config(run: RunSpec):
    from quadsim.physics.wind import wind_from_text
    from quadsim.sim.config import SimConfig
    from quadsim.vehicle.params import SHIPPED_VEHICLES

    return SimConfig(
        urdf=SHIPPED_VEHICLES[run.airframe],
        controller=run.controller.kind,
        wind=wind_from_text(run.wind, run.turbulence),
        seed=run.seed,
    )


def fly_run(task: RunTask) -> dict[str, Any]:
    """Fly one run headless and return its table row (never raises for a run that cannot fly:
    the row says why)."""
    from quadsim.drivers.scripted import ScriptedDriver, load_script
    from quadsim.sim.loop import StateLog
    from quadsim.sim.simulator import Simulator

    run = task.run
    row: dict[str, Any] = {"index": run.index, "key": run.key, **run.axes()}
    row.update(dict.fromkeys(METRICS, math.nan))
    row.update(status="error", failed_limits="", error="", recording="")
    try:
        script = load_script(run.scenario)
        duration = run.duration_s if run.duration_s is not None else script.duration_s
        config = _config(run)
        gains = dict(run.controller.gains) or None
        with Simulator(config, ScriptedDriver(script), controller_gains=gains) as sim:
            log = StateLog()
            sim.add_sink(log)
            recorded = _start_recording(task, sim, script.name) if task.record else None
            try:
                sim.run_for(duration)
            finally:
                if recorded is not None:
                    recorded.close()
            metrics = flight_metrics(log.states, log.commands, config.rates.physics_hz, sim.events)
        row.update(metrics)
        failed = [
            name for name, limit in task.limits if not math.isnan(metrics.get(name, math.nan)) and metrics[name] > limit
        ]
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


def _start_recording(task: RunTask, sim: Any, script_name: str):
    from quadsim.session.outputs import OutputOptions, RecordedRun

    run = task.run
    folder = Path(task.record_dir or ".")
    name = f"{run.index:05d}_" + "_".join(str(v) for v in run.axes().values())
    options = OutputOptions(record=True, out=folder / f"{_safe(name)}.mcap", cameras=())
    info = {"command": "sweep", "script": script_name, "key": run.key}
    return RecordedRun(sim, sim.description(), options, f"sweep_{run.index}", info)


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "._-" else "-" for c in name)[:200]
