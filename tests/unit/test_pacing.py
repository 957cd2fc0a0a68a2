"""One pacer: every real-time loop (the window, headless real-time and live runs, replay playback)
steps by quadsim.session.pacing, and no other module paces against the wall clock. Tested with an
injected clock: deterministic, whatever the machine is doing."""

from __future__ import annotations

import ast
from pathlib import Path

from quadsim.drivers.scripted import ScriptedDriver, load_script
from quadsim.session.pacing import FixedStepPacer, FrameCap, RealTimePacer
from quadsim.session.plan import RunPlan
from quadsim.session.run import Run
from quadsim.sim.config import SimConfig
from tests.helpers import ROOT

PACKAGE = ROOT / "quadsim"
PACER = PACKAGE / "session" / "pacing.py"
#: waits on the wall clock that are not a run's pacing, and why
NOT_PACING = {
    # a client's message budget per second, and the back-off before a resubscription: the
    # Foxglove port's own network bookkeeping, in its event loop
    PACKAGE / "live" / "foxglove_front.py": "asyncio.sleep",
}


class FakeClock:
    """A wall clock that moves only when told to (or when the pacer sleeps)."""

    def __init__(self) -> None:
        self.now = 64.0  # whole and binary fractions of a second: the arithmetic below is exact
        self.slept: list[float] = []

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.slept.append(seconds)
        self.now += seconds


def _sleeps(path: Path) -> list[str]:
    """Every call of a sleep in `path`: time.sleep, a bare sleep imported from time, asyncio.sleep;
    and pygame's own waits on the wall clock (a pygame.time.Clock, whose tick sleeps; delay, wait)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Call):
            f = node.func
            if isinstance(f, ast.Attribute) and f.attr == "sleep" and isinstance(f.value, ast.Name):
                found.append(f"{f.value.id}.sleep")
            elif isinstance(f, ast.Name) and f.id == "sleep":
                found.append("sleep")
            elif (
                isinstance(f, ast.Attribute)
                and f.attr in ("Clock", "delay", "wait")
                and ast.unparse(f.value).endswith("time")
            ):
                found.append(f"{ast.unparse(f.value)}.{f.attr}")
        elif isinstance(node, ast.ImportFrom) and node.module == "time":
            found += [f"from time import {a.name}" for a in node.names if a.name == "sleep"]
    return found


def test_no_module_but_the_pacer_waits_on_the_wall_clock():
    offenders = []
    for path in sorted(PACKAGE.rglob("*.py")):
        allowed = NOT_PACING.get(path)
        for call in _sleeps(path):
            if path != PACER and call != allowed:
                offenders.append(f"{path.relative_to(PACKAGE.parent)}: {call}")
    assert not offenders, "pacing outside quadsim/session/pacing.py:\n" + "\n".join(offenders)


def test_the_check_sees_a_sleep(tmp_path):
    """The walk must be able to fail: a loop sleeping on its own is caught, however it is imported."""
    module = tmp_path / "paced.py"
    module.write_text("import time\nfrom time import sleep\nwhile True:\n    time.sleep(0.01)\n    sleep(1)\n")
    assert _sleeps(module) == ["from time import sleep", "time.sleep", "sleep"]
    module.write_text("import pygame\nclock = pygame.time.Clock()\nwhile True:\n    pygame.time.delay(10)\n")
    assert _sleeps(module) == ["pygame.time.Clock", "pygame.time.delay"]


def test_steps_follow_the_wall_clock_at_any_speed_and_a_backlog_is_given_up():
    clock = FakeClock()
    pacer = RealTimePacer(240, max_frame_s=0.125, clock=clock)
    clock.now += 0.0625
    assert pacer.steps_for_frame(0) == 15 and not pacer.lagging
    clock.now += 1.0  # a stall: 1 s of steps are due, at most 0.125 s of them are taken
    assert pacer.steps_for_frame(15) == 30 and pacer.lagging
    clock.now += 0.125
    assert pacer.steps_for_frame(45) == 30  # from where it gave up, not the whole backlog
    pacer.rebase(1000, speed=2.0)
    clock.now += 0.0625
    assert pacer.steps_for_frame(1000) == 30 and not pacer.lagging  # twice as fast


def test_a_headless_runs_pacer_catches_up_after_a_stall():
    clock = FakeClock()
    pacer = RealTimePacer(240, max_frame_s=None, clock=clock)
    clock.now += 1.0  # a stall: all of it is due, and taken
    assert pacer.steps_for_frame(0) == 240 and not pacer.lagging


def test_wait_sleeps_until_the_steps_are_due_and_stops_when_asked():
    clock = FakeClock()
    pacer = RealTimePacer(240, clock=clock, sleep=clock.sleep)
    pacer.wait(240)
    assert abs(clock.now - 65.0) < 1e-9 and max(clock.slept) <= 0.05  # in pieces, a stop is heard
    clock.slept.clear()
    pacer.wait(480, stop=lambda: len(clock.slept) >= 3)
    assert len(clock.slept) == 3 and clock.now < 66.0


def test_a_paced_headless_run_flies_its_whole_duration_at_the_clocks_pace():
    """Run.fly with the pacer: every step of the plan, and the (fake) wall time it took is the
    simulated time: real time."""
    clock = FakeClock()
    script = load_script("hover")
    plan = RunPlan.alone(SimConfig(), ScriptedDriver(script), duration_s=2.0)
    with Run(plan) as run:
        summaries = run.fly(RealTimePacer(240, clock=clock, sleep=clock.sleep), stop=lambda: False)
    assert summaries[""].sim_time_s == 2.0 and run.fleet.closed
    assert abs((clock.now - 64.0) - 2.0) < 0.02


def test_a_fixed_step_pacer_steps_the_same_every_frame():
    pacer = FixedStepPacer(240, 1 / 30)
    assert [pacer.steps_for_frame(n) for n in (0, 8, 16)] == [8, 8, 8]
    pacer.rebase(16, speed=0.5)
    assert pacer.steps_for_frame(16) == 4


def test_a_paced_run_catches_up_a_chunk_at_a_time():
    """Behind the wall clock, a paced run steps what is due a chunk (1/60 s) at a time, with its
    progress, its cameras' frames and a stop request seen between chunks, not in one burst."""
    clock = FakeClock()
    plan = RunPlan.alone(SimConfig(), ScriptedDriver(load_script("hover")), duration_s=1.0)
    flown: list[float] = []

    def stall_once(flown_s: float) -> None:
        flown.append(flown_s)
        if len(flown) == 1:
            clock.now += 0.5  # the machine stalls half a second after the first chunk

    with Run(plan) as run:
        run.fly(RealTimePacer(240, max_frame_s=None, clock=clock, sleep=clock.sleep), stall_once, stop=lambda: False)
    steps = [round(b * 240) - round(a * 240) for a, b in zip([0.0, *flown], flown)]
    assert sum(steps) == 240 and max(steps) == 4  # a chunk at a time, the half second caught up too


def test_a_frame_cap_sleeps_what_is_left_of_each_frame_and_never_makes_up_a_slow_one():
    clock = FakeClock()
    cap = FrameCap(64, clock=clock, sleep=clock.sleep)  # 1/64 s a frame: exact in binary
    cap.wait()  # the first frame: nothing to wait for
    clock.now += 0.00390625  # a frame drawn in a quarter of its time
    cap.wait()
    clock.now += 0.0625  # a slow frame: four frames' time
    cap.wait()
    clock.now += 0.0078125  # half of a frame
    cap.wait()
    assert clock.slept == [0.01171875, 0.0078125]
