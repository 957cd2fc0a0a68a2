"""The flight core against the bare PyBullet loop for the same URDF and world.

Flight core:
  baseline   the bare PyBullet loop for this URDF and world, loaded as PyBullet loads it by default
             (a tree of fixed joints): a force on each rotor link + stepSimulation
  merged     the same with the URDF's fixed links merged into one body, as the simulator loads it
  physics    the loop stepping PhysicsWorld with a constant command, no controller, driver or sinks
             (motor lag, forces, yaw torque, drag, state read, the loop's own bookkeeping)
  full loop  SimLoop at 240 Hz physics and 240 Hz control: driver polling, command gate,
             controller, physics and state publishing, hovering at 2 m; quadsim steps the
             vehicle itself while it is clear of everything (quadsim.physics.free_flight), and
             the same loop with PyBullet stepping it every step (physics = "pybullet") beside it
Each figure is the best of several repeats (the least disturbed by other work on the machine).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from quadsim.apps.bench.figures import Figure, best_of
from quadsim.control import ControllerKind
from quadsim.core.types import ActiveCommand, RotorForces, Stepping, Twist, VehicleState, ZMode
from quadsim.physics.client import WorldClient
from quadsim.physics.pybullet_quiet import pb
from quadsim.physics.scene import inertial_offset, load_vehicle_body
from quadsim.physics.world_spec import load_world
from quadsim.sim.config import Rates, SimConfig
from quadsim.sim.loop import SimLoop, StateLog
from quadsim.sim.simulator import Simulator
from quadsim.vehicle.params import load_vehicle


class Timed:
    """Something to time step by step: `run(n)` steps it n times, at `physics_hz` steps a
    simulated second; `close()` frees it."""

    def __init__(
        self, name: str, run: Callable[[int], object], close: Callable[[], object], physics_hz: int = 240
    ) -> None:
        self.name, self.run, self.close, self.physics_hz = name, run, close, physics_hz

    def figure(self, steps: int, repeats: int) -> Figure:
        """Timed alone, then closed: the best of `repeats` runs of `steps` steps."""
        try:
            return Figure(self.name, best_of(repeats, steps, self.run), self.physics_hz)
        finally:
            self.close()


def interleaved(timed: list[Timed], steps: int, rounds: int) -> list[Figure]:
    """Each of `timed` run `steps` steps in turn, for `rounds` rounds; the best run of each. Taken
    in turn, a burst of other work on the machine slows a round of all of them, not every run of
    one of them, so the ratios between them hold. Closes them all."""
    best = [math.inf] * len(timed)
    try:
        for _ in range(rounds):
            for i, item in enumerate(timed):
                t0 = time.perf_counter()
                item.run(steps)
                best[i] = min(best[i], (time.perf_counter() - t0) / steps)
    finally:
        for item in timed:
            item.close()
    return [Figure(item.name, seconds, item.physics_hz) for item, seconds in zip(timed, best)]


def bare_pybullet_loop(merged: bool = False, physics_hz: int = 240) -> Timed:
    """A bare loop: this URDF and world in PyBullet, a force at each rotor and one step, nothing
    else. The baseline loads the URDF as PyBullet does by default (a tree of fixed joints, as
    a user or a peer loads it, and as quadsim did before 0.3); `merged`: as the simulator loads
    it now, its fixed links merged into one body."""
    vehicle = load_vehicle()
    client = WorldClient(load_world(), physics_hz, vehicle.gravity_mps2)
    cid = client.cid
    body = load_vehicle_body(vehicle, cid, (0.0, 0.0, 2.0), (0.0, 0.0, 0.0, 1.0), merged=merged)
    if merged:  # at each hub, from the merged body's inertial frame
        offset = inertial_offset(body, cid) or (0.0, 0.0, 0.0)
        hubs = [(-1, tuple(h - o for h, o in zip(hub, offset))) for hub in vehicle.rotor_hubs_m]
    else:  # on each rotor link
        links = {
            pb.getJointInfo(body, i, physicsClientId=cid)[12].decode(): i
            for i in range(pb.getNumJoints(body, physicsClientId=cid))
        }
        hubs = [(links[r.link_name], (0.0, 0.0, 0.0)) for r in vehicle.rotors]
    hover = vehicle.hover_thrust_per_rotor_n

    def run(n: int) -> None:
        force = (0.0, 0.0, hover)
        link_frame = pb.LINK_FRAME
        for i in range(n):
            if i % 240 == 0:  # keep it in the air: a free body drifts and tumbles slowly
                pb.resetBasePositionAndOrientation(body, (0, 0, 2.0), (0, 0, 0, 1), physicsClientId=cid)
                pb.resetBaseVelocity(body, (0, 0, 0), (0, 0, 0), physicsClientId=cid)
            for link, at in hubs:
                pb.applyExternalForce(body, link, force, at, link_frame, physicsClientId=cid)
            pb.stepSimulation(physicsClientId=cid)

    name = "bare PyBullet loop, fixed links merged" if merged else "bare PyBullet loop (baseline)"
    return Timed(name, run, client.close, physics_hz)


def hovering_sim(controller: ControllerKind, rates: Rates, physics: Stepping = Stepping.QUADSIM) -> Simulator:
    sim = Simulator(SimConfig(controller=controller, z_mode=ZMode.HEIGHT, rates=rates, physics=physics))
    sim.send(Twist())  # height mode, linear.z = 0: hold 2.0 m
    sim.add_sink(StateLog())
    sim.run_for(3.0)  # take off and settle before timing
    return sim


class _ConstantForces:
    """A stand-in controller asking for the same rotor forces every step, so that a loop
    stepped with it costs physics and bookkeeping alone."""

    kind = ControllerKind.CASCADE  # the Controller protocol names a kind; nothing reads it here

    def __init__(self, forces: RotorForces) -> None:
        self.forces = forces

    def reset(self) -> None:
        pass

    def update(self, state: VehicleState, command: ActiveCommand, dt_s: float) -> RotorForces:
        return self.forces

    def describe(self) -> dict[str, Any]:
        return {"name": "constant", "forces_n": list(self.forces)}


def physics_only() -> Timed:
    """The loop stepping the physics world with constant rotor forces: no controller, driver or sinks."""
    sim = hovering_sim(ControllerKind.CASCADE, Rates())
    phys = sim.physics
    hover = _ConstantForces((sim.vehicle.hover_thrust_per_rotor_n,) * sim.vehicle.rotor_count)
    loop = SimLoop(phys, hover, sim.gate, sim.config.rates)  # no driver, no sinks

    def run(n: int) -> None:
        for done in range(0, n, 240):
            # as the baseline: keep the uncontrolled body in the air (placed through the world,
            # so that the attitude it turns forces with is the one it is given)
            phys.place((0.0, 0.0, 2.0), (0.0, 0.0, 0.0, 1.0))
            loop.run(min(240, n - done))

    return Timed("physics stepped by the loop, constant forces", run, sim.close)


def controller_only(controller: ControllerKind) -> Timed:
    """One controller update per step on a recorded hover state (no physics at all)."""
    sim = hovering_sim(controller, Rates())
    state, active, ctrl = sim.state, sim.gate.active(sim.step_count), sim.controller

    def run(n: int) -> None:
        update = ctrl.update
        for _ in range(n):
            update(state, active, 1.0 / 240.0)

    return Timed(f"{controller.value} controller update alone", run, sim.close)


def full_loop(controller: ControllerKind = ControllerKind.CASCADE, physics: Stepping = Stepping.QUADSIM) -> Timed:
    """The whole loop at 240 Hz physics and control, hovering at 2 m."""
    sim = hovering_sim(controller, Rates(physics_hz=240, control_hz=240, state_hz=60, input_hz=20), physics)
    by = ", PyBullet stepping" if physics is Stepping.PYBULLET else ""
    return Timed(f"full loop, {controller.value} controller @240 Hz{by}", sim.step, sim.close)


def run_flight_core_bench(steps: int = 6000, repeats: int = 8, out: Callable[[str], None] = print) -> dict[str, Figure]:
    out(
        f"quadsim bench: flight core ({steps} steps per run, each figure in turn for {repeats} round{'s' * (repeats != 1)}, "
        "the best run of each; 240 Hz physics)"
    )
    keys = ("bare", "bare_merged", "physics", "cascade_update", "cascade", "cascade_pybullet", "seed")
    timed = [
        bare_pybullet_loop(),
        bare_pybullet_loop(merged=True),
        physics_only(),
        controller_only(ControllerKind.CASCADE),
        full_loop(ControllerKind.CASCADE),
        full_loop(ControllerKind.CASCADE, Stepping.PYBULLET),
        full_loop(ControllerKind.SEED),
    ]
    figures = dict(zip(keys, interleaved(timed, steps, repeats)))
    base = figures["bare"]
    out(f"  {'':46s} {'us/step':>8s} {'steps/s':>9s} {'x real time':>11s} {'x baseline':>10s}")
    for fig in figures.values():
        ratio = fig.seconds_per_step / base.seconds_per_step
        out(
            f"  {fig.name:46s} {fig.seconds_per_step * 1e6:8.1f} {fig.steps_per_s:9.0f} "
            f"{fig.real_time_factor:10.1f}x {ratio:9.2f}x"
        )
    cascade, merged, pybullet = figures["cascade"], figures["bare_merged"], figures["cascade_pybullet"]
    ok_rt = cascade.real_time_factor >= 400.0
    ratio = cascade.seconds_per_step / base.seconds_per_step
    out(
        f"  target: full loop >= 400x real time [{'met' if ok_rt else 'MISSED'}], "
        f"<= 0.8x the baseline [{'met' if ratio <= 0.8 else 'MISSED'}: {ratio:.2f}x; "
        f"{cascade.seconds_per_step / merged.seconds_per_step:.2f}x the merged bare loop; "
        f"{pybullet.seconds_per_step / cascade.seconds_per_step:.2f}x faster than PyBullet stepping it]"
    )
    return figures
