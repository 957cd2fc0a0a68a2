"""MkDocs hooks: the command-line reference is generated from quadsim's own parser at build time,
so the page and `--help` cannot disagree (tests/unit/test_docs.py checks the built page against `--help`)."""

from __future__ import annotations

import argparse
import os
from typing import Any

MARKER = "<!-- cli-reference -->"
#: the help's width: what a code block holds between the site's navigation and its table of
#: contents at 1280 px without wrapping (docs/stylesheets/extra.css wraps what is wider)
COLUMNS = 66


def cli_reference() -> str:
    """Markdown: the top-level help, then each command's, as `--help` prints them in a terminal
    COLUMNS wide."""
    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(COLUMNS)  # argparse reads the width when it formats
    try:
        return _cli_reference()
    finally:
        if previous is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = previous


def _cli_reference() -> str:
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
