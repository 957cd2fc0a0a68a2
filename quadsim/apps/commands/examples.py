"""`quadsim examples`: the example programs and sweep files that ship inside the package, listed,
and copied into a folder of the user's choice to run and change."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from quadsim.apps.commands import add_command_parser
from quadsim.assets import shipped_examples
from quadsim.core.files import write_whole
from quadsim.errors import QuadsimError


def summary(path: Path, width: int = 100) -> str:
    """An example's first sentence of explanation (a program's docstring, a sweep or fleet file's
    comment), whole, or cut at a word with an ellipsis when longer than `width`."""
    paragraph: list[str] = []
    for line in path.read_text(encoding="utf-8").splitlines():
        text = line.strip().strip('"').lstrip("#").strip()
        if text:
            paragraph.append(text)
        elif paragraph:
            break  # the end of the first paragraph
    first = re.match(r".*?\.(?=\s|$)", " ".join(paragraph))
    sentence = first.group(0) if first else " ".join(paragraph)
    if len(sentence) <= width:
        return sentence
    return sentence[: sentence.rfind(" ", 0, width - 1)] + " \u2026"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command_parser(
        sub,
        "examples",
        description="List the examples that ship inside the package; --copy DIR copies them (all, or the "
        "NAMEs given) into DIR to run and change. Nothing in DIR is overwritten.",
    )
    p.add_argument("names", nargs="*", metavar="NAME", help="examples to copy (default: all)")
    p.add_argument("--copy", type=Path, default=None, metavar="DIR", help="copy them into DIR (created if needed)")


def main(args: argparse.Namespace) -> int:
    examples = shipped_examples()
    unknown = [n for n in args.names if n not in examples]
    if unknown:
        raise QuadsimError(f"no example named {unknown[0]!r}; the examples are {', '.join(examples)}")
    if args.copy is None:
        if args.names:
            raise QuadsimError("name examples together with --copy DIR, which says where they go")
        for name, path in examples.items():
            print(f"{name:24s} {summary(path)}")
        return 0
    chosen = args.names or list(examples)
    folder: Path = args.copy
    clashes = [n for n in chosen if (folder / n).exists()]
    if clashes:
        raise QuadsimError(f"{folder / clashes[0]} exists: nothing was copied (choose another folder)")
    copied: list[Path] = []
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for name in dict.fromkeys(chosen):  # names come from the package, never the user; each once
            _copy(examples[name], folder / name)
            copied.append(folder / name)
    except OSError as exc:
        for path in copied:  # all or none: a retry is not refused by the half copied
            path.unlink(missing_ok=True)
        raise QuadsimError(
            f"cannot copy the examples into {folder}: {exc.strerror or exc}; nothing was copied"
        ) from None
    for path in copied:
        print(f"copied          {path}")
    return 0


def _copy(src: Path, dst: Path) -> None:
    """`src` copied to `dst`, whole or not at all (never over a file that is there)."""
    data = src.read_bytes()  # an example: a few kB
    write_whole(dst, lambda fh: fh.write(data), f"{dst} exists: choose another folder")
