"""TOML files read within bounds: size, nesting, and every failure one ConfigError naming the file.

World, vehicle parameter, gains, joystick mapping and sweep files are input a user may have been
handed: a file of a million nested arrays must give one line, not a RecursionError or a minute
of parsing. `tomllib` is the standard library's from Python 3.11, tomli before.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from quadsim.errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised only on Python 3.10
    import tomli as tomllib

__all__ = ["MAX_TOML_BYTES", "MAX_TOML_DEPTH", "read_toml", "tomllib"]

#: the largest TOML file quadsim reads (its own are a few kB)
MAX_TOML_BYTES = 1024 * 1024
#: tables and arrays within each other, at most (its own go 3 deep)
MAX_TOML_DEPTH = 16


def read_toml(path: Path, what: str) -> dict[str, Any]:
    """The table in the TOML file at `path`, a `what` ("world file", ...); ConfigError if it is
    missing, unreadable, larger than MAX_TOML_BYTES, not UTF-8, not TOML or nested deeper than
    MAX_TOML_DEPTH (naming the key)."""
    try:
        with path.open("rb") as fh:
            raw = fh.read(MAX_TOML_BYTES + 1)
    except FileNotFoundError:
        raise ConfigError(f"{what} not found: {path}") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: a folder, not a {what}") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read this {what}: {exc.strerror or exc}") from None
    if len(raw) > MAX_TOML_BYTES:
        raise ConfigError(f"{path}: a {what} may be at most {MAX_TOML_BYTES // 1024} kB; this one is larger")
    try:
        table: dict[str, Any] = tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not a UTF-8 text file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc})") from None
    except RecursionError:  # arrays or inline tables nested past what the parser's recursion allows
        raise ConfigError(f"{path}: nested deeper than {MAX_TOML_DEPTH} levels") from None
    too_deep = _too_deep(table)
    if too_deep is not None:
        raise ConfigError(f"{path}: {too_deep} is nested deeper than {MAX_TOML_DEPTH} levels")
    return table


def _too_deep(table: dict[str, Any]) -> str | None:
    """The key of the first value nested past MAX_TOML_DEPTH, or None (walked without recursion)."""
    stack: list[tuple[str, Any, int]] = [(key, value, 1) for key, value in table.items()]
    while stack:
        key, value, depth = stack.pop()
        if depth > MAX_TOML_DEPTH:
            return key.split(".")[0].split("[")[0]
        if isinstance(value, dict):
            stack += [(f"{key}.{k}", v, depth + 1) for k, v in value.items()]
        elif isinstance(value, list):
            stack += [(f"{key}[{i}]", v, depth + 1) for i, v in enumerate(value)]
    return None
