"""The command line: `quadsim COMMAND --help` (or `.venv/bin/python main.py`, `python -m quadsim`).

Each command lives in its own module of quadsim.apps.commands; this module assembles the parser,
importing the module of the command that runs (and no other: the one place quadsim loads lazily
what a command needs), and turns what a command raises into one line and an exit code: 2 for a
usage or input error, 130, 143 and 129 for SIGINT, SIGTERM and SIGHUP (a run stops at its next safe point),
141 for a closed pipe."""

from __future__ import annotations

import argparse
import errno
import logging
import os
import re
import sys
from collections.abc import Iterable
from typing import NoReturn

from quadsim import __version__
from quadsim.apps.commands import BY_NAME, COMMANDS
from quadsim.apps.options import program
from quadsim.errors import QuadsimError
from quadsim.live import FOXGLOVE_DEFAULT_ENDPOINT
from quadsim.session.stopping import SignalStop, StopRequested
from quadsim.session.stopping import describe as describe_stop
from quadsim.session.stopping import exit_code as stop_exit_code


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (and exit code 2), like every other error here."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser(commands: Iterable[str] | None = None) -> argparse.ArgumentParser:
    """The parser; `commands`: the names of the commands whose modules are imported for their
    options (None: every command's, as the docs' reference needs); the others are listed."""
    loaded = None if commands is None else {BY_NAME[name].name for name in commands}
    parser = _Parser(
        prog=program(),
        description="Quadrotor teleop simulator: PyBullet physics flying Twist commands (/quad_cmd_twist semantics).",
        epilog=f"Run '{program()} COMMAND --help' for each command's options.",
    )
    parser.add_argument("--version", action="version", version=f"quadsim {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log more")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for command in COMMANDS:
        if loaded is None or command.name in loaded:
            command.module().add_parser(sub)
        else:
            command.add_parser(sub)
    return parser


def _command_named(argv: list[str]) -> str | None:
    """The command `argv` asks for (its first word that is not an option), if it names one."""
    word = next((arg for arg in argv if not arg.startswith("-")), None)
    return word if word in BY_NAME else None


def main(argv: list[str] | None = None) -> int:
    """The command line. SIGINT, SIGTERM and SIGHUP stop any command cleanly (exit 130, 143, 129)."""
    with SignalStop() as stop:
        try:
            code = _main(argv)
        except StopRequested as exc:  # a second signal: stopped at once
            print(f"quadsim: {describe_stop(exc.signum)}", file=sys.stderr)
            return stop_exit_code(stop.signum or exc.signum)
        except Exception as exc:
            if stop.signum is None:
                raise
            # what a forced stop broke on its way out (an import cut short, a closed pipe)
            print(f"quadsim: {describe_stop(stop.signum)} ({type(exc).__name__} on the way out)", file=sys.stderr)
            return stop_exit_code(stop.signum)
        if stop.signum is not None and code != stop_exit_code(stop.signum):
            # stopped by a signal, whatever else happened on the way out: the exit code says so
            if code == 0:  # it came after the command had said its last word
                print(
                    f"quadsim: {describe_stop(stop.signum)} once the command had finished: nothing was cut short",
                    file=sys.stderr,
                )
            elif code != 1:
                print(f"quadsim: {describe_stop(stop.signum)}", file=sys.stderr)
            return stop_exit_code(stop.signum)
        return code


#: options whose value may start with a minus sign (argparse would read `--wind -5,90` as two options)
_SIGNED_VALUE_OPTIONS = ("--wind",)
_SIGNED_VALUE = re.compile(r"-[0-9.][0-9.,eE+-]*")


def _normalise_argv(argv: list[str]) -> list[str]:
    """What argparse would misread, said the way it reads it: `--wind -5,90` as `--wind=-5,90` (a
    negative speed is a value, not an option), and `--foxglove FILE.mcap` as `--foxglove` at its
    default endpoint followed by the file (`replay --foxglove FILE` took the file for HOST:PORT)."""
    out: list[str] = []
    for arg in argv:
        if out and out[-1] in _SIGNED_VALUE_OPTIONS and _SIGNED_VALUE.fullmatch(arg):
            out[-1] = f"{out[-1]}={arg}"
            continue
        if out and out[-1] == "--foxglove" and arg.lower().endswith(".mcap"):
            out[-1] = f"--foxglove={FOXGLOVE_DEFAULT_ENDPOINT}"
        out.append(arg)
    return out


def _main(argv: list[str] | None) -> int:
    words = _normalise_argv(list(sys.argv[1:] if argv is None else argv))
    command = _command_named(words)
    parser = build_parser([command] if command is not None else [])
    args, extra = parser.parse_known_args(words)
    if extra:  # said by the command's own parser, which names its own --help
        commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        commands.choices.get(args.command, parser).error(f"unrecognized arguments: {' '.join(extra)}")
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.WARNING, format="quadsim: %(levelname)s: %(message)s"
    )
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        code = int(args.func(args))
        sys.stdout.flush()  # inside the try: a closed pipe shows here, not at interpreter exit
        return code
    except QuadsimError as exc:
        print(f"quadsim: error: {exc.cli_message}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader went away (`quadsim info X | head`): stop quietly, as Unix tools do
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            print(f"quadsim: error: the disk is full ({exc.filename or 'writing'})", file=sys.stderr)
            return 2
        raise
