"""One module per command of the command line, each owning its options: `add_parser(sub)`
declares the command and its options (shared groups come from quadsim.apps.options), `main(args)`
carries it out and returns the exit code.

`COMMANDS` names them, in `--help`'s order, with their one line of help: the command line imports
a command's module only when that command runs (or its own `--help` is asked for), so `quadsim
--help` and each command load what they use and nothing of the others."""

from __future__ import annotations

import argparse
import importlib
from dataclasses import dataclass
from types import ModuleType
from typing import Any


@dataclass(frozen=True)
class Command:
    """A command: its name, its one line of `--help`, and other names it answers to."""

    name: str
    help: str
    aliases: tuple[str, ...] = ()

    def module(self) -> ModuleType:
        """The command's module (quadsim.apps.commands.NAME), imported now."""
        return importlib.import_module(f"{__name__}.{self.name}")

    def add_parser(self, sub: argparse._SubParsersAction, **kwargs: Any) -> argparse.ArgumentParser:
        """The command's parser, with its name, aliases and help (its module adds its options)."""
        parser: argparse.ArgumentParser = sub.add_parser(
            self.name, aliases=list(self.aliases), help=self.help, **kwargs
        )
        return parser


COMMANDS = (
    Command("run", "fly a script, a bag's commands, live clients' Twists or a fleet headless, and summarise it"),
    Command("fly", "fly with keyboard or gamepad in a window (no display: a demo)", ("demo",)),
    Command("scenarios", "list the built-in scripted scenarios"),
    Command("evaluate", "fly the scenarios with each controller and print the flight-quality table"),
    Command("info", "describe a recording: duration, topics, rates, run parameters"),
    Command(
        "layout",
        "write a Foxglove layout that shows every vehicle, its cameras and plots, for a recording or a live run",
    ),
    Command("recover", "salvage a recording cut short (killed process, power loss)"),
    Command("replay", "play a recording back (window, or --headless summary, MP4, plot), or fly it again (--resim)"),
    Command("check", "re-fly recordings as regression tests (exit 1 when one changed)"),
    Command(
        "sweep",
        "fly every combination of a sweep file (scenarios x controllers x airframes x wind x seeds) "
        "and tabulate their flight metrics",
    ),
    Command("examples", "list the example programs and sweep files that ship with quadsim, or copy them to a folder"),
    Command("bench", "measure speed against a bare-PyBullet baseline run in the same process"),
)
#: every name a command answers to
BY_NAME = {name: c for c in COMMANDS for name in (c.name, *c.aliases)}


def add_command_parser(sub: argparse._SubParsersAction, name: str, **kwargs: Any) -> argparse.ArgumentParser:
    """Command `name`'s parser, with its name, aliases and help from COMMANDS, carried out by its
    module's `main` (called from that module's `add_parser`, once the module is loaded)."""
    command = BY_NAME[name]
    parser = command.add_parser(sub, **kwargs)
    parser.set_defaults(func=command.module().main)
    return parser
