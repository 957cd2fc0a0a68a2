"""TOML files read within bounds: size, nesting, and every failure one ConfigError naming the file.

World, vehicle parameter, gains, joystick mapping and sweep files are input a user may have been
handed: a file of a million nested arrays must give one line, not a RecursionError or a minute
of parsing. `tomllib` is the standard library's from Python 3.11, tomli before. A key a table
does not know is refused too (`refuse_unknown_keys`), the nearest known one suggested: a typo
must not be silently ignored.
"""

from __future__ import annotations

import difflib
import re
import sys
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from quadsim.errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised only on Python 3.10
    import tomli as tomllib

__all__ = ["MAX_TOML_BYTES", "MAX_TOML_DEPTH", "near_miss", "read_toml", "refuse_unknown_keys", "tomllib"]

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


#: a key TOML writes without quotes
_BARE_KEY = re.compile(r"[A-Za-z0-9_-]{1,60}")


def near_miss(key: str, known: Iterable[str]) -> str | None:
    """The known key `key` is most likely a typo of (difflib's closest, if close enough), or None."""
    matches = difflib.get_close_matches(key, list(known), n=1, cutoff=0.6)
    return matches[0] if matches else None


def refuse_unknown_keys(
    table: Mapping[str, Any],
    known: Sequence[str],
    where: str,
    *,
    top_level: bool = False,
    otherwise: str | None = None,
) -> None:
    """ConfigError for the first key of `table` (in the file's order) not among `known`:
    "{where}: unknown key 'fricton' (did you mean 'friction'?)", `where` naming the file and the
    table. With no known key near it, `otherwise` (else the known keys) is said in the brackets.

    `top_level`: `table` is a whole file, whose tables are spelled as TOML writes them
    ("unknown table [[landmarks]] (did you mean [[landmark]]?)")."""
    unknown = [key for key in table if key not in known]
    if not unknown:
        return
    key = unknown[0]
    value = table[key]
    bare = top_level and _BARE_KEY.fullmatch(key) is not None  # else quoted, as a key: one line
    if bare and isinstance(value, dict):
        noun, spell = "table", "[{}]"
    elif bare and isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        noun, spell = "table", "[[{}]]"
    else:
        noun, spell = "key", "{!r}"
    shown = key if len(key) <= 60 else key[:57] + "..."
    near = near_miss(key, known)
    if near is not None:
        tail = f"did you mean {spell.format(near)}?"
    else:
        tail = otherwise if otherwise is not None else f"known: {', '.join(known)}"
    raise ConfigError(f"{where}: unknown {noun} {spell.format(shown)} ({tail})")
