"""The code reads like its architecture: a command is a module of quadsim.apps.commands, and no
function runs over 60 lines unless its docstring says why it is one piece."""

from __future__ import annotations

import ast
import importlib
import pkgutil
from pathlib import Path

import quadsim
import quadsim.apps.commands as commands

PACKAGE = Path(quadsim.__file__).parent
MAX_LINES = 60
#: a long function's docstring says why it is one piece with these words
REASON = "one piece"


def long_functions(source: str, where: str) -> list[str]:
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            lines = (node.end_lineno or node.lineno) - node.lineno + 1
            if lines > MAX_LINES and REASON not in (ast.get_docstring(node) or "").lower():
                found.append(f"{where}:{node.lineno} {node.name} ({lines} lines)")
    return found


def test_no_function_over_60_lines_without_a_reason():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        found += long_functions(path.read_text(encoding="utf-8"), str(path.relative_to(PACKAGE.parent)))
    assert not found, "functions over 60 lines whose docstring does not say why they are one piece:\n" + "\n".join(
        found
    )


def test_the_shape_check_sees_a_long_function_and_its_reason():
    body = "".join(f"    x{i} = {i}\n" for i in range(MAX_LINES))
    assert long_functions(f"def f():\n{body}", "m.py") == ["m.py:1 f (61 lines)"]
    reasoned = f'def f():\n    """It is one piece: a table."""\n{body}'
    assert long_functions(reasoned, "m.py") == []


def test_every_command_is_a_module_with_its_parser_and_its_main():
    modules = {m.name for m in pkgutil.iter_modules(commands.__path__)}
    listed = {c.name for c in commands.COMMANDS}
    assert modules == listed, "a module of quadsim.apps.commands is missing from COMMANDS, or the reverse"
    for name in sorted(modules):
        module = importlib.import_module(f"quadsim.apps.commands.{name}")
        assert callable(module.add_parser) and callable(module.main), name


def test_the_command_line_names_each_command_after_its_module():
    from quadsim.apps.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for command in commands.COMMANDS:
        assert sub.choices[command.name].get_default("func") is command.module().main, command.name
