"""The command-line interface: `python main.py COMMAND --help` (or the `quadsim` script)."""

from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path

from quadsim import __version__
from quadsim.control import ControllerKind
from quadsim.errors import QuadsimError
from quadsim.loop import Rates
from quadsim.messages import ZMode
from quadsim.physics import StartPose

DEMO_SCENARIO = "figure8"


def _add_sim_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("simulation")
    g.add_argument("--controller", choices=[c.value for c in ControllerKind], default=ControllerKind.CASCADE.value,
                   help="cascade (default): velocity->attitude->rate; seed: port of the original V-REP controller")
    g.add_argument("--z-mode", choices=[z.value for z in ZMode], default=None,
                   help="how linear.z is read: velocity = climb rate m/s; height = altitude 2.0+z m "
                        "(default: what the script says, else velocity)")
    g.add_argument("--urdf", type=Path, default=None, help="vehicle URDF (default: assets/urdf/quadsim_x.urdf)")
    g.add_argument("--world", type=Path, default=None, help="world file (default: assets/worlds/default.toml)")
    g.add_argument("--physics-hz", type=int, default=240, help="physics rate (default 240)")
    g.add_argument("--control-hz", type=int, default=240, help="controller rate; must divide the physics rate (default 240)")
    g.add_argument("--state-hz", type=int, default=60, help="state publishing rate; must divide the physics rate (default 60)")
    g.add_argument("--input-hz", type=int, default=20, help="command publishing rate of the driver (default 20)")
    g.add_argument("--timeout", type=float, default=0.5, metavar="S",
                   help="dead-man timeout: hold position after S seconds without a command (default 0.5)")
    g.add_argument("--gui", action="store_true", help="also open PyBullet's own 3D window (needs a display)")


def _config(args: argparse.Namespace, script_z_mode: ZMode | None):
    from quadsim.sim import SimConfig

    z_mode = ZMode(args.z_mode) if args.z_mode else (script_z_mode or ZMode.VELOCITY)
    rates = Rates(physics_hz=args.physics_hz, control_hz=args.control_hz, state_hz=args.state_hz, input_hz=args.input_hz)
    return SimConfig(urdf=args.urdf, world=args.world, controller=ControllerKind(args.controller), z_mode=z_mode,
                     rates=rates, command_timeout_s=args.timeout, start=StartPose(), gui=args.gui)


def _fly_script(args: argparse.Namespace, script_name: str, realtime: bool) -> int:
    from quadsim.drivers.scripted import ScriptedDriver, load_script
    from quadsim.headless import run_headless
    from quadsim.progress import ProgressBar
    from quadsim.sim import Simulator

    script = load_script(script_name)
    config = _config(args, script.z_mode)
    duration = args.duration if args.duration is not None else script.duration_s
    if not duration > 0:
        raise QuadsimError(f"--duration must be > 0 s, got {duration}")
    print(f"flying '{script.name}' for {duration:.1f} s: controller {config.controller.value}, "
          f"z-mode {config.z_mode.value}, physics {config.rates.physics_hz} Hz, control {config.rates.control_hz} Hz")
    bar = ProgressBar(duration, "sim time")
    with Simulator(config, ScriptedDriver(script)) as sim:
        try:
            summary = run_headless(sim, duration, progress=bar.update, realtime=realtime)
        except KeyboardInterrupt:
            bar.close()
            print(f"interrupted at sim time {sim.time_s:.2f} s", file=sys.stderr)
            return 130
        bar.close()
    for line in summary.lines():
        print(line)
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    return _fly_script(args, args.script, realtime=args.gui)


def cmd_fly(args: argparse.Namespace) -> int:
    has_display = bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")) and os.environ.get("SDL_VIDEODRIVER") != "dummy"
    if not has_display:
        print(f"No display found: flying the scripted demo '{DEMO_SCENARIO}' headless instead. "
              f"(Other flights: python main.py run --script NAME; list them with: python main.py scenarios)")
        args.gui = False
        return _fly_script(args, DEMO_SCENARIO, realtime=False)
    print(f"Flying the scripted demo '{DEMO_SCENARIO}' in PyBullet's window, in real time. "
          f"(The keyboard/gamepad teleop window is not built yet.)")
    args.gui = True
    return _fly_script(args, DEMO_SCENARIO, realtime=True)


def cmd_scenarios(args: argparse.Namespace) -> int:
    from quadsim.drivers.scripted import builtin_scenarios, load_script

    for name, summary in builtin_scenarios().items():
        script = load_script(name)
        print(f"{name:14s} {script.duration_s:5.1f} s  {summary}")
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    from quadsim.flight_metrics import SCENARIO_METRICS, TARGETS, evaluate

    controllers = [ControllerKind(c) for c in args.controller] if args.controller else list(ControllerKind)
    results = {c: evaluate(controller=c) for c in controllers}
    rows = [(s, m) for s, fn in SCENARIO_METRICS.items() for m in results[controllers[0]][s]
            if m not in ("max_tilt_deg", "min_z_m", "max_z_m", "rate_mean_radps", "peak_mps")]
    targets = {(s, m): bound for s, m, bound in TARGETS}
    header = f"| scenario | metric | target (cascade) | " + " | ".join(c.value for c in controllers) + " |"
    print(header)
    print("|" + "---|" * (3 + len(controllers)))
    for s, m in rows:
        bound = targets.get((s, m))
        cells = " | ".join(f"{results[c][s][m]:.3f}" for c in controllers)
        print(f"| {s} | {m} | {'< ' + format(bound, 'g') if bound is not None else ''} | {cells} |")
    print("| " + " | ".join(["all", "max tilt (deg)", ""] + [f"{max(r['max_tilt_deg'] for r in results[c].values()):.1f}" for c in controllers]) + " |")
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from quadsim.bench import run_flight_core_bench

    run_flight_core_bench(steps=args.steps, repeats=args.repeats)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="quadsim",
        description="Quadrotor teleop simulator: PyBullet physics flying Twist commands (/quad_cmd_twist semantics).",
        epilog="Run 'python main.py COMMAND --help' for each command's options.")
    parser.add_argument("--version", action="version", version=f"quadsim {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log more")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("run", help="fly a scripted flight headless, as fast as possible, and summarise it",
                       description="Fly a built-in scenario or a script file headless as fast as the machine allows, "
                                   "showing progress, then print sim time, wall time, real-time factor, final pose "
                                   "and distance flown. Script format: see README (or quadsim/drivers/scripted.py).")
    p.add_argument("--script", required=True, metavar="NAME|FILE",
                   help="a built-in scenario (python main.py scenarios lists them) or a script file")
    p.add_argument("--duration", type=float, default=None, metavar="S",
                   help="seconds of sim time (default: the script's length; beyond it the vehicle holds)")
    _add_sim_options(p)
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("fly", aliases=["demo"], help="fly (with no display: a scripted demo flight, said so)",
                       description="Fly the vehicle. With no display this flies the scripted demo flight headless "
                                   "and says so.")
    p.add_argument("--duration", type=float, default=None, metavar="S", help="seconds of sim time for the demo")
    _add_sim_options(p)
    p.set_defaults(func=cmd_fly)

    p = sub.add_parser("scenarios", help="list the built-in scripted scenarios")
    p.set_defaults(func=cmd_scenarios)

    p = sub.add_parser("evaluate", help="fly the scenarios with each controller and print the flight-quality table",
                       description="Fly every measured scenario and print its metrics as a Markdown table "
                                   "(the README's table comes from here).")
    p.add_argument("--controller", action="append", choices=[c.value for c in ControllerKind],
                   help="only this controller (repeatable; default: all)")
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("bench", help="measure speed against a bare-PyBullet baseline run in the same process",
                       description="Benchmark. Every figure is given as steps/s, real-time factor and a ratio to a "
                                   "baseline measured in the same run; best of --repeats.")
    p.add_argument("--steps", type=int, default=24000, help="physics steps per timed run (default 24000 = 100 s sim)")
    p.add_argument("--repeats", type=int, default=3, help="timed runs per figure; the best is kept (default 3)")
    p.set_defaults(func=cmd_bench)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.WARNING, format="quadsim: %(levelname)s: %(message)s")
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return args.func(args)
    except QuadsimError as exc:
        print(f"quadsim: error: {exc}", file=sys.stderr)
        return 2
