"""`quadsim recover`: salvage the intact chunks of a recording cut short into a valid MCAP."""

from __future__ import annotations

import argparse
from pathlib import Path

from quadsim.apps.commands import add_command_parser
from quadsim.recording.contract import CORE_TOPICS
from quadsim.recording.mcap_scan import bag_file
from quadsim.recording.salvage import recover


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command_parser(
        sub,
        "recover",
        description="Read every complete chunk of a damaged or cut-short MCAP file and write its "
        "messages, schemas, metadata and attachments to a new, valid, indexed MCAP.",
    )
    p.add_argument("file", type=Path, metavar="DAMAGED.mcap", help="the recording, or a ros2 bag's folder holding one")
    p.add_argument(
        "-o",
        "--output",
        type=Path,
        default=None,
        metavar="OUT.mcap",
        help="where to write (default: DAMAGED.recovered.mcap beside the input; for a bag's folder, "
        "FOLDER.recovered.mcap beside the folder)",
    )


def main(args: argparse.Namespace) -> int:

    if args.output is None and args.file.is_dir():  # beside the bag's folder: a second .mcap in it would
        args.output = args.file.with_name(args.file.name + ".recovered.mcap")  # leave the folder ambiguous
    args.file = bag_file(args.file)
    result = recover(args.file, args.output, CORE_TOPICS)
    t0, t1 = result.span_s
    if result.was_complete:
        print(f"{args.file} was complete; its {result.messages} messages were copied to {result.path}")
        return 0
    print(
        f"recovered {result.messages} messages on {result.topics} topics from {result.chunks} intact chunks, "
        f"covering {t0:.2f} .. {t1:.2f} s of simulation time, with {result.metadata} metadata records and "
        f"{result.attachments} attachments"
    )
    lost = [d for d in result.damage if d.loses != "nothing"]
    print("what was lost:" + (" nothing (only indexes or fields around the data were damaged)" if not lost else ""))
    for d in result.damage:
        print(f"  {d.describe()}")
    print(f"written to {result.path}")
    return 0
