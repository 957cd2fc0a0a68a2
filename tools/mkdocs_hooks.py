"""MkDocs hooks: the command-line reference is generated from quadsim's own parser at build time,
so the page and `--help` cannot disagree (tests/test_docs.py checks the built page against `--help`)."""

from __future__ import annotations

import argparse
from typing import Any

MARKER = "<!-- cli-reference -->"


def cli_reference() -> str:
    """Markdown: the top-level help, then each command's, as `--help` prints them."""
    from quadsim.apps.cli import build_parser

    parser = build_parser()
    parser.prog = "quadsim"
    sections = ["## quadsim", "", "```text", parser.format_help().rstrip(), "```", ""]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            seen: set[int] = set()
            for name, sub in action.choices.items():
                if id(sub) in seen:  # an alias (demo for fly): one section per command
                    continue
                seen.add(id(sub))
                sub.prog = f"quadsim {name}"
                sections += [f"## quadsim {name}", "", "```text", sub.format_help().rstrip(), "```", ""]
    return "\n".join(sections)


def on_page_markdown(markdown: str, page: Any, **_: Any) -> str:
    if MARKER in markdown:
        return markdown.replace(MARKER, cli_reference())
    return markdown
