"""One run, the one way every run is flown: a plan opened (its fleet built, an odometer on every
vehicle, its outputs and live bridges attached), stepped to its end (`fly`: headless, as fast as
the machine allows or paced to the wall clock) or frame by frame (the teleop window), then
summarised vehicle by vehicle and closed, whatever ends it.

    with Run(plan) as run:
        summaries = run.fly(progress=bar.update)

`run`, headless `fly`, `sweep`, `check` and `replay --resim`, `evaluate`, the pytest plugin and
the bench all fly through here; the window opens a Run and steps it. Its vehicles are a
quadsim.sim.fleet.Fleet (one vehicle: a fleet of one).
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable

from quadsim.core.types import ZMode
from quadsim.session.outputs import RecordedRun
from quadsim.session.pacing import Pacer, collect_start_up_garbage
from quadsim.session.plan import RunPlan
from quadsim.session.stopping import stop_requested
from quadsim.session.summary import Odometer, RunSummary, camera_line
from quadsim.sim.config import steps_of
from quadsim.sim.fleet import Fleet

#: simulation time between two progress updates of a run flown as fast as it goes
PROGRESS_EVERY_S = 0.5
#: simulation time a paced run steps at least at once (a window's frame, at 60 frames a second)
PACED_CHUNK_S = 1.0 / 60.0


def to_the_end() -> bool:
    """A `stop` for runs that fly to their end whatever comes (a sweep's runs and re-flights:
    a signal stops them between runs, so no row or report comes from half a flight)."""
    return False


class Run:
    """A plan opened: its fleet (`fleet`, or one given: a sweep worker's kept fleet, restarted),
    an odometer on every vehicle and the outputs (`outputs`). Use as a context manager: closing
    finishes the recording and closes the live bridges, then the fleet if the run built it."""

    def __init__(self, plan: RunPlan, fleet: Fleet | None = None, say: Callable[[str], None] | None = None) -> None:
        """`say`: told what opening the run spends time on, as it starts it (a first compile of
        the flight core, the cameras), once the files it reads have been found good."""
        self.plan = plan
        self._owns_fleet = fleet is None
        self.fleet = fleet if fleet is not None else _build(plan, say)
        try:
            self.odometers = {drone.name: Odometer(drone) for drone in self.fleet.members}
            for drone in self.fleet.members:
                drone.add_sink(self.odometers[drone.name])
            cameras = _camera_count(plan)
            if say is not None and cameras:
                workers = plan.outputs.render_workers
                say(
                    f"starting {cameras} camera{'s' * (cameras != 1)}"
                    + (f" and {workers} render workers" if workers else "")
                )
            self.outputs = RecordedRun(
                self.fleet, plan.outputs, plan.label, dict(plan.run_info), plan.live, plan.cameras
            )
        except BaseException:
            self._close_fleet()
            raise
        self._start_step = self.fleet.step_count
        self._flown_before_s = 0.0  # simulated time flown before the last reset
        self._switches = sorted(plan.z_switches, key=lambda s: s[0])
        self.wall_s = 0.0  # wall time spent stepping
        self.stopped_early = False
        self.paced = False  # flown paced to the wall clock (its cameras then drop frames rather than wait)

    @property
    def end_step(self) -> int:
        """The step the plan's duration ends at (a plan without an end: never)."""
        if math.isinf(self.plan.duration_s):
            return sys.maxsize
        return self._start_step + steps_of(self.plan.duration_s, self.fleet.config.rates.physics_hz)

    # --- stepping -------------------------------------------------------------------------------

    def step(self, steps: int) -> None:
        """Advance every vehicle `steps` physics steps, making the plan's z-mode switches at their steps."""
        fleet = self.fleet
        target = fleet.step_count + steps
        while self._switches and self._switches[0][0] <= target:
            at, name, mode = self._switches.pop(0)
            if at > fleet.step_count:
                fleet.step(at - fleet.step_count)
            self.switch_z_mode(name, mode)
        if target > fleet.step_count:
            fleet.step(target - fleet.step_count)

    def reset(self) -> None:
        """Every vehicle back to the start (the window's Backspace); the summaries' camera rates
        still count what was flown before (they divided every frame by the time since the reset)."""
        self._flown_before_s = self.flown_s
        self.fleet.reset()
        self._start_step = self.fleet.step_count

    def switch_z_mode(self, name: str, mode: ZMode) -> None:
        """Vehicle `name` reads linear.z in `mode` from now on; the recording keeps the switch
        under that vehicle, where a re-flight makes it again."""
        self.fleet[name].set_z_mode(mode)
        self.outputs.note_event(self.fleet.step_count, "z_mode", mode.value, vehicle=name)

    def fly(
        self,
        pacer: Pacer | None = None,
        progress: Callable[[float], None] | None = None,
        stop: Callable[[], bool] = stop_requested,
    ) -> dict[str, RunSummary]:
        """Step to the plan's end, or until `stop()` says so (looked at between chunks), as fast
        as the machine allows or paced by `pacer`; `progress(sim seconds flown)` after every
        chunk. Each vehicle's summary, by name."""
        fleet = self.fleet
        hz = fleet.config.rates.physics_hz
        start, end = fleet.step_count, self.end_step
        chunk = max(1, round((PACED_CHUNK_S if pacer is not None else PROGRESS_EVERY_S) * hz))
        if pacer is not None:
            self.paced = True
            collect_start_up_garbage()
            pacer.rebase(start)
        t0 = time.perf_counter()
        while fleet.step_count < end and not stop():
            done = fleet.step_count
            if pacer is None:
                steps = chunk
            else:  # a chunk at a time, catching up too: between chunks, progress, frames and a stop are seen
                pacer.wait(done + chunk, stop)
                steps = min(pacer.steps_for_frame(done), chunk)
            steps = min(steps, end - done)
            if steps > 0:
                self.step(steps)
                if pacer is not None:  # real time: frames are handed on as soon as they are in
                    self.outputs.poll()
                if progress is not None:
                    progress((fleet.step_count - start) / hz)
        self.wall_s += time.perf_counter() - t0
        self.stopped_early = fleet.step_count < end
        self.outputs.drain()  # the frames still being rendered count in the summary (and go in the file)
        return self.summaries()

    @property
    def flown_s(self) -> float:
        """Simulated time flown in this run, over every reset (each starts the clock again)."""
        return self._flown_before_s + (self.fleet.step_count - self._start_step) / self.fleet.config.rates.physics_hz

    def summaries(self) -> dict[str, RunSummary]:
        """What each vehicle did so far, by name (with what its cameras delivered)."""
        flown_s = self.flown_s
        pipelines = self.outputs.pipelines
        return {
            name: odometer.summary(
                self.wall_s,
                self.stopped_early,
                camera_line(pipelines[name], flown_s, self.paced) if name in pipelines else "",
            )
            for name, odometer in self.odometers.items()
        }

    # --- lifetime -------------------------------------------------------------------------------

    def close(self) -> None:
        try:
            self.outputs.close()
        finally:
            for drone in self.fleet.members:
                drone.remove_sink(self.odometers[drone.name])
            self._close_fleet()

    def _close_fleet(self) -> None:
        if self._owns_fleet:
            self.fleet.close()

    def __enter__(self) -> Run:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _build(plan: RunPlan, say: Callable[[str], None] | None) -> Fleet:
    return Fleet(plan.vehicles, plan.config, plan.landing, plan.reset_on_crash, plan.texture_required, plan.wind, say)


def _camera_count(plan: RunPlan) -> int:
    """How many cameras `plan` flies (a fleet's: every vehicle's)."""
    if plan.cameras is not None:
        return sum(len(specs) for specs in plan.cameras.values())
    return len(plan.outputs.cameras)


def fly(
    plan: RunPlan,
    pacer: Pacer | None = None,
    progress: Callable[[float], None] | None = None,
    stop: Callable[[], bool] = stop_requested,
) -> dict[str, RunSummary]:
    """Open `plan`, fly it to its end (see Run.fly) and close it: each vehicle's summary, by name."""
    with Run(plan) as run:
        return run.fly(pacer, progress, stop)
