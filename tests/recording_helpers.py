"""Helpers for recording tests: fly a short scripted flight with recording on."""

from pathlib import Path

from quadsim import SimConfig, Simulator, StateLog, ZMode
from quadsim.drivers.scripted import ScriptedDriver, parse_script
from quadsim.sensors.camera import default_cameras
from quadsim.session.outputs import OutputOptions, RecordedRun

SCRIPT = "z_mode height\n2.0 linear.z=0\n1.0 linear.x=1.0 angular.z=0.5\n"


def record_flight(path: Path, workers: int = 0, size=(160, 120), cameras=True, script: str = SCRIPT) -> StateLog:
    parsed = parse_script(script, "test")
    log = StateLog()
    with Simulator(SimConfig(z_mode=parsed.z_mode or ZMode.VELOCITY), ScriptedDriver(parsed)) as sim:
        sim.add_sink(log)
        options = OutputOptions(out=path, cameras=default_cameras(*size, 30) if cameras else (), render_workers=workers)
        with RecordedRun(sim, sim.description(), options, "test", {"script": "test"}):
            sim.run_for(parsed.duration_s)
    return log
