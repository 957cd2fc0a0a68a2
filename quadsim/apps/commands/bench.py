"""`quadsim bench`: speed, as ratios against a baseline measured in the same run, section by section."""

from __future__ import annotations

import argparse
import os

from quadsim.apps.bench.sections import SECTIONS
from quadsim.apps.commands import add_command_parser
from quadsim.apps.options import whole
from quadsim.core import compiled  # here: numba's import is not every command's


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command_parser(
        sub,
        "bench",
        description="Benchmark. Every figure is given as steps/s, real-time factor and a ratio to a "
        "baseline measured in the same run, the best of several runs. The first two lines say the machine's load and "
        "whether the flight core is compiled (numba, installed with quadsim where it has wheels).",
    )
    p.add_argument(
        "--steps",
        type=whole(1, 10_000_000),
        default=6000,
        help="flight section: physics steps per timed run (default 6000 = 25 s of simulation)",
    )
    p.add_argument(
        "--repeats",
        type=whole(1, 100),
        default=8,
        help="flight section: timed runs per figure, taken in turn with the other figures' runs; "
        "the best of each is kept (default 8)",
    )
    p.add_argument(
        "--section",
        choices=["all", *SECTIONS],
        default="all",
        help="; ".join(f"{name}: {section.what}" for name, section in SECTIONS.items()) + " (default: all)",
    )


def main(args: argparse.Namespace) -> int:

    print(_load("before"))
    print(compiled.status())
    for name, section in SECTIONS.items():
        if args.section in ("all", name):
            if name == "flight":
                section.run(steps=args.steps, repeats=args.repeats)
            else:
                section.run()
    print(_load("after"))
    return 0


def _load(when: str) -> str:
    """The machine's load average: figures taken beside other work are not comparable."""
    try:
        one, five, fifteen = os.getloadavg()
    except OSError:  # not available on this platform
        return f"load average {when}: unknown"
    return (
        f"load average {when}: {one:.2f} (1 min), {five:.2f} (5 min), {fifteen:.2f} (15 min) on {os.cpu_count()} cores"
    )
