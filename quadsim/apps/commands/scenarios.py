"""`quadsim scenarios`: the built-in scripted flights, with their lengths."""

from __future__ import annotations

import argparse

from quadsim.apps.commands import add_command_parser
from quadsim.drivers.scripted import builtin_scenarios, load_script


def add_parser(sub: argparse._SubParsersAction) -> None:
    add_command_parser(
        sub,
        "scenarios",
        description="List the built-in scripted scenarios, each with its length and what it flies. "
        "Fly one with 'run --script NAME'; a script file of your own is 'run --script FILE.qscript'.",
    )


def main(args: argparse.Namespace) -> int:

    for name, summary in builtin_scenarios().items():
        script = load_script(name)
        print(f"{name:14s} {script.duration_s:5.1f} s  {summary}")
    return 0
