"""Headless flights from the command line, as `run` and a display-less `fly` make them: a plan
(quadsim.apps.plans: a script, a bag's commands, live clients' Twists, a fleet file) flown with
its live bridges and a progress bar, then summarised (vehicle by vehicle for a fleet), with the
recording's line and an exit code. The flight itself is a quadsim.session.run.Run."""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import replace

from quadsim.apps.options import live_outputs, stopped_by_signal
from quadsim.apps.plans import Planned
from quadsim.core.types import ZMode
from quadsim.drivers.subscribed import SubscribedDriver
from quadsim.errors import ConfigError
from quadsim.session.outputs import RecordedRun
from quadsim.session.pacing import RealTimePacer
from quadsim.session.plan import RunPlan
from quadsim.session.progress import ProgressBar
from quadsim.session.run import Run
from quadsim.session.stopping import StopRequested
from quadsim.session.summary import RunSummary


class HeadlessFlight:
    """One headless flight of the command line: its live bridges opened, its run flown with a
    progress bar (none when flown live), then its summary and recording printed, and an exit code."""

    def __init__(self, args: argparse.Namespace, planned: Planned) -> None:
        self.args, self.planned = args, planned
        self.summaries: dict[str, RunSummary] = {}
        self.outputs: RecordedRun | None = None
        self.sim_time = 0.0

    def fly(self) -> int:
        """Fly the plan to its end (or a signal), record it, print what happened."""
        planned = self.planned
        live = live_outputs(self.args, planned.live_inputs or None)
        bar = None
        try:
            with self._open(replace(planned.plan, live=tuple(live))) as run:
                # said once the world and the vehicles have loaded: a bad file is the only line, not the second
                print(headline(run, planned.what))
                self.outputs = run.outputs
                if run.outputs.path is not None:
                    print(f"recording to {run.outputs.path}", flush=True)
                bar = ProgressBar(planned.plan.duration_s, "sim time", eta=True) if not planned.live_inputs else None
                hz = run.fleet.config.rates.physics_hz
                try:
                    # paced, a headless run catches up after a stall (live inputs keep their rate)
                    pacer = RealTimePacer(hz, max_frame_s=None) if planned.realtime else None
                    self.summaries = run.fly(pacer, _progress(bar, pacer, run, planned.live_inputs))
                finally:
                    self.sim_time = run.fleet.time_s
        except StopRequested:
            pass  # the summary of what was flown follows; the exit code says why it stopped
        finally:
            if bar is not None:
                bar.close()
            for output in live:  # closed with the run, or here if the run never started
                output.close()
        return self.report()

    def _open(self, plan: RunPlan) -> Run:
        """The run; a vehicle of a fleet file that cannot fly (two too close, a start on a
        landmark) is said with the file."""
        try:
            return Run(plan, say=_say_on_stderr)
        except ConfigError as exc:
            source = self.planned.source
            if source is None:
                raise
            raise ConfigError(f"{source}: {exc}", f"{source}: {exc.cli_message}") from None

    def report(self) -> int:
        """The summary (each vehicle's, for a fleet), the recording, and why it stopped; the exit code."""
        if len(self.summaries) == 1 and "" in self.summaries:
            for line in self.summaries[""].lines():
                print(line)
        elif self.summaries:
            first = next(iter(self.summaries.values()))
            print(f"sim time        {first.sim_time_s:.2f} s")
            print(f"wall time       {first.wall_time_s:.2f} s")
            print(f"real-time factor {first.real_time_factor:.1f}x")
            width = max(len(name) for name in self.summaries)
            for name, summary in self.summaries.items():
                print(f"{name:<{width}}  {summary.vehicle_line()}")
                for line in summary.lines():
                    if line.startswith(("crash", "live input")):
                        print(f"{name:<{width}}  {line}")  # under its vehicle, named again
        return report_end(self.outputs, self.sim_time, self.planned.plan.duration_s)


#: a paced run says it is behind real time when it is more than this behind, at most every BEHIND_EVERY_S
BEHIND_S, BEHIND_EVERY_S = 1.0, 10.0
#: a run flown by live inputs (no end to count down to) says how it goes at 1 s of simulated time
#: (it is up, its clock runs), then every LIVE_EVERY_S
LIVE_FIRST_S, LIVE_EVERY_S = 1.0, 10.0


def _live_line(flown_s: float, wall_s: float, drivers: Sequence[SubscribedDriver]) -> str:
    """`live: 10 s flown (1.00x real time); 200 Twists and 1 goal from ros2`."""
    twists = sum(d.received for d in drivers)
    goals = sum(d.goals_received for d in drivers)
    names = " and ".join(sorted({d.name for d in drivers}))
    pace = f" ({flown_s / wall_s:.2f}x real time)" if wall_s > 0 else ""
    got = f"{twists} Twist{'s' * (twists != 1)}" + (f" and {goals} goal{'s' * (goals != 1)}" if goals else "")
    return f"live: {flown_s:.0f} s flown{pace}; {got} from {names}"


def _progress(
    bar: ProgressBar | None, pacer: RealTimePacer | None, run: Run, live: Sequence[SubscribedDriver] = ()
) -> Callable[[float], None] | None:
    """What a headless flight does after each chunk: the progress bar, or with live inputs a
    line now and then (`_live_line`), and, paced to the wall clock, a line on stderr while the
    run falls behind real time (at most every 10 s)."""
    if pacer is None:
        return bar.update if bar is not None else None
    said = [-math.inf]
    next_live, started = [LIVE_FIRST_S], time.monotonic()

    def progress(flown_s: float) -> None:
        if bar is not None:
            bar.update(flown_s)
        if live and flown_s >= next_live[0]:
            next_live[0] = (flown_s // LIVE_EVERY_S + 1) * LIVE_EVERY_S
            print(_live_line(flown_s, time.monotonic() - started, live), file=sys.stderr, flush=True)
        behind = pacer.behind_s(run.fleet.step_count)
        now = time.monotonic()
        if behind > BEHIND_S and now - said[0] >= BEHIND_EVERY_S:
            said[0] = now
            print(
                f"quadsim: {behind:.1f} s behind real time at sim time {flown_s:.1f} s: the machine cannot keep up "
                "(fewer cameras, smaller images or a quieter machine help)",
                file=sys.stderr,
                flush=True,
            )

    return progress


def headline(run: Run, what: str) -> str:
    """What flies and how: the controller and z-mode of a run of one vehicle, or a fleet's
    vehicles (in `what`), the rates, the cameras and the wind."""
    config, outputs = run.fleet.config, run.outputs
    rates = f"physics {config.rates.physics_hz} Hz, control {config.rates.control_hz} Hz"
    wind = f", {config.wind.describe()}" if config.wind.enabled else ""
    if run.fleet.members[0].name:  # a fleet: each vehicle's cameras
        seen = ", ".join(f"{name} ({', '.join(p.name for p in specs)})" for name, specs in _cameras(outputs).items())
        return f"flying {what}; {rates}, cameras {seen or 'none'}{wind}"
    cams = ", ".join(f"{c.name} {c.width_px}x{c.height_px}@{c.rate_hz}Hz" for c in outputs.description.cameras)
    z_mode = (config.z_mode or ZMode.VELOCITY).value
    return (
        f"flying {what}: controller {config.controller.value}, z-mode {z_mode}, {rates}, cameras {cams or 'none'}{wind}"
    )


def _cameras(outputs: RecordedRun) -> dict[str, tuple]:
    return {name: d.cameras for name, d in outputs.description.fleet if d.cameras}


def report_end(outputs: RecordedRun | None, sim_time: float, planned_s: float | None = None) -> int:
    """The recording's line and why the run stopped (a signal, a recording that failed); the
    exit code. `planned_s`: how long the run was to fly (a signal after the last step came while
    it was finishing)."""
    recorder = outputs.recorder if outputs is not None else None
    if recorder is not None:
        path = outputs.path if outputs is not None else None
        if recorder.error:
            print(f"recording       {recorder.error}")
        else:
            size = path.stat().st_size / 1e6 if path is not None and path.exists() else 0.0
            print(f"recording       {path or ''} ({size:.1f} MB, {recorder.message_count} messages)")
    saved = "; the recording is finished and readable" if recorder is not None and not recorder.error else ""
    when = f"at sim time {sim_time:.2f} s"
    if planned_s is not None and sim_time >= planned_s - 1e-9:
        when = f"while finishing, after all {sim_time:.2f} s were flown"
    code = stopped_by_signal(f" {when}{saved}")
    if code is not None:
        return code
    if recorder is not None and recorder.error:
        print("quadsim: error: the flight finished but its recording did not (see above)", file=sys.stderr)
        return 1
    return 0


def _say_on_stderr(note: str) -> None:
    """What the run starts that takes time, said before the wait, on stderr beside the progress."""
    print(f"quadsim: {note}...", file=sys.stderr, flush=True)
