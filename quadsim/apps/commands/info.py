"""`quadsim info`: what a recording holds, and what is wrong with a damaged one."""

from __future__ import annotations

import argparse
from pathlib import Path

from quadsim.apps.commands import add_command_parser
from quadsim.errors import QuadsimError
from quadsim.recording.info import read_info
from quadsim.recording.mcap_scan import bag_file


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command_parser(
        sub,
        "info",
        description="Describe an MCAP recording (quadsim's, or another program's: a note says what it "
        "lacks). On a damaged file, say what is wrong and how much is readable (exit code 2).",
    )
    p.add_argument("file", type=Path, metavar="FILE.mcap", help="the recording, or a ros2 bag's folder holding one")


def main(args: argparse.Namespace) -> int:

    args.file = bag_file(args.file)
    info = read_info(args.file)
    if info.damage:  # said before any of the report: one line, what is readable and what to run
        raise QuadsimError(info.damage_report)
    for line in info.lines():
        print(line)
    missing = info.missing_topics()
    if missing:  # a sound file another program wrote: described, not an error
        print(
            f"note        not a quadsim recording (no {', '.join(missing)}): replay shows what it has"
            + (", run --commands-from flies its /quad_cmd_twist" if "/quad_cmd_twist" not in missing else "")
        )
    return 0
