"""The fleet section of `bench`: 1, 4, 10 and 25 hovering vehicles in one world, no cameras; the
cost of a vehicle-step against one Simulator's step measured in the same run. Then 10 vehicles
recorded to MCAP, with and without one vehicle's two cameras (320x240 at 30 Hz, by render workers
that hold the whole fleet), against one vehicle recording the same cameras."""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable
from pathlib import Path

from quadsim.apps.bench.figures import best_of, best_seconds
from quadsim.core.types import StartPose, Twist, ZMode
from quadsim.sim.config import SimConfig
from quadsim.sim.fleet import Fleet, FleetVehicle
from quadsim.sim.simulator import Simulator

SIZES = (1, 4, 10, 25)
#: a grid 1.5 m apart in a clear corner of the default world
SPACING_M, ORIGIN = 1.5, (-12.0, 6.0)


def _grid(size: int) -> tuple[FleetVehicle, ...]:
    """`size` vehicles on a grid in a clear corner of the default world."""
    side = math.ceil(math.sqrt(size))
    return tuple(
        FleetVehicle(f"v{i}", start=StartPose(ORIGIN[0] + SPACING_M * (i % side), ORIGIN[1] + SPACING_M * (i // side)))
        for i in range(size)
    )


def _hovering_fleet(size: int) -> Fleet:
    fleet = Fleet(_grid(size), SimConfig(z_mode=ZMode.HEIGHT))
    for name in fleet:
        fleet[name].send(Twist())  # hold 2 m
    fleet.run_for(2.0)
    return fleet


def run_fleet_bench(out: Callable[[str], None] = print, steps: int = 2400, repeats: int = 3) -> None:
    out(f"quadsim bench: fleets hovering in one world, no cameras ({steps} steps per run, best of {repeats})")
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT)) as sim:
        sim.send(Twist())
        sim.run_for(2.0)
        one = best_of(repeats, steps, sim.step)
    out(f"  one Simulator (baseline)   {one * 1e6:8.1f} us/step   {1 / one / 240:6.1f}x real time")
    ten = math.nan
    for size in SIZES:
        with _hovering_fleet(size) as fleet:
            per_step = best_of(repeats, steps, fleet.step)
        out(
            f"  {size:3d} vehicles             {per_step * 1e6:8.1f} us/step   {1 / per_step / 240:6.1f}x real time   "
            f"{per_step / size * 1e6:6.1f} us a vehicle-step ({per_step / size / one:.2f}x the baseline's step)"
        )
        ten = 1 / per_step / 240 if size == 10 else ten
    out(f"  target: cost linear in the vehicles; 10 vehicles at >= 30x real time [{'met' if ten >= 30 else 'MISSED'}]")

    _recorded(out)


def _recorded(out: Callable[[str], None], seconds: float = 5.0) -> None:
    """Real-time factors of recorded runs: a wall-clock second per simulated second is 1x."""
    from quadsim.sensors.camera import default_cameras
    from quadsim.session.outputs import OutputOptions
    from quadsim.session.plan import RunPlan
    from quadsim.session.run import Run, to_the_end

    cameras = default_cameras(320, 240, 30)
    out(f"  recorded to MCAP, {seconds:g} s simulated each (best of 2):")
    with tempfile.TemporaryDirectory(prefix="quadsim-bench-") as tmp:
        folder = Path(tmp)

        def one_vehicle() -> float:
            options = OutputOptions(out=folder, cameras=cameras)
            plan = RunPlan.alone(SimConfig(z_mode=ZMode.HEIGHT), duration_s=seconds, outputs=options, label="bench")
            with Run(plan) as run:
                run.fleet.members[0].send(Twist())
                return best_seconds(lambda: run.fly(stop=to_the_end))

        def ten(with_cameras: bool) -> float:
            with _hovering_fleet(10) as fleet:
                plan = RunPlan(
                    fleet.config,
                    _grid(10),
                    duration_s=seconds,
                    outputs=OutputOptions(out=folder, cameras=()),
                    cameras={"v0": cameras} if with_cameras else {},
                    label="bench",
                )
                with Run(plan, fleet) as run:
                    return best_seconds(lambda: run.fly(stop=to_the_end))

        baseline = min(one_vehicle() for _ in range(2))
        rows = [
            ("one vehicle, its 2 cameras (baseline)", baseline),
            ("10 vehicles, state only", min(ten(False) for _ in range(2))),
            ("10 vehicles, one with 2 cameras", min(ten(True) for _ in range(2))),
        ]
    for label, wall in rows:
        out(f"  {label:<50} {seconds / wall:6.1f}x real time   ({wall / baseline:.2f}x the baseline's wall time)")
    out("  target: 10 vehicles with one vehicle's cameras at >= 1x real time")
