"""`quadsim evaluate`: every measured scenario flown by each controller, as the docs' Markdown table."""

from __future__ import annotations

import argparse

from quadsim.apps.commands import add_command_parser
from quadsim.apps.flight_quality import MANOEUVRE_TARGETS, PHYSICS_TARGETS, SCENARIO_METRICS, TARGETS, evaluate
from quadsim.control import ControllerKind


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command_parser(
        sub,
        "evaluate",
        description="Fly every measured scenario and print its metrics as a Markdown table.",
    )
    p.add_argument(
        "--controller",
        action="append",
        choices=[c.value for c in ControllerKind],
        help="only this controller (repeatable; default: all)",
    )


#: metrics the table leaves out (the tests read them)
DETAILS = {"max_tilt_deg", "min_z_m", "max_z_m", "rate_mean_radps", "peak_mps"}
DETAILS |= {"landed", "final_z_m", "drops", "heading_rate_radps", "bank_deg"}


def main(args: argparse.Namespace) -> int:

    controllers = [ControllerKind(c) for c in args.controller] if args.controller else list(ControllerKind)
    results = {c: evaluate(controller=c) for c in controllers}
    rows = [(s, m) for s, metrics in results[controllers[0]].items() for m in metrics if m not in DETAILS]
    targets = {(s, m): "< " + format(bound, "g") for s, m, bound in (*TARGETS, *MANOEUVRE_TARGETS)}
    targets.update({(s, m): f"{low:g} .. {high:g}" if low else f"< {high:g}" for s, m, low, high in PHYSICS_TARGETS})
    header = "| scenario | metric | target (cascade) | " + " | ".join(c.value for c in controllers) + " |"
    print(header)
    print("|" + "---|" * (3 + len(controllers)))
    for s, m in rows:
        cells = " | ".join(f"{results[c][s][m]:.3f}" for c in controllers)
        print(f"| {s} | {m} | {targets.get((s, m), '')} | {cells} |")
    tilts = [f"{max(results[c][s]['max_tilt_deg'] for s in SCENARIO_METRICS):.1f}" for c in controllers]
    print("| " + " | ".join(["all scenarios", "max tilt (deg)", "", *tilts]) + " |")
    return 0
