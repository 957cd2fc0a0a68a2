"""A user's own part (a controller, a wind model) named by where its class lives, so that a
recording says what flew and a re-flight can make it again.

A part's import path is `package.module:ClassName`. Making it again imports that module (the
user's own code, installed or on the Python path, as running their script would) and builds the
class as its documented constructor says; a class defined in the program itself (`__main__`), one
that does not import, or something that is not such a part is said in one line (QuadsimError).
Only a dotted module name and a class's qualified name are accepted: a recording cannot name a
file path, and nothing is called before the class is found to have the part's methods.
"""

from __future__ import annotations

import importlib
import inspect
import re
from typing import Any

from quadsim.errors import QuadsimError

#: `package.module:Class.Inner`, nothing else (no file paths, no calls, no private modules)
IMPORT_PATH = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*(\.[A-Za-z_]\w*)*")
#: the longest import path accepted from a recording
MAX_IMPORT_PATH = 300


def import_path(part: object) -> str:
    """Where `part`'s class lives, as `module:QualifiedName`."""
    cls = type(part)
    return f"{cls.__module__}:{cls.__qualname__}"


def part_class(path: str, what: str, methods: tuple[str, ...]) -> type:
    """The class `path` names, imported: a `what` (e.g. "controller") with `methods`. Anything
    else, or a module that does not import, is a QuadsimError saying why in one line."""
    if not isinstance(path, str) or len(path) > MAX_IMPORT_PATH or not IMPORT_PATH.fullmatch(path):
        raise QuadsimError(f"the {what} {str(path)[:80]!r} is not an import path (package.module:ClassName)")
    module_name, qualname = path.split(":")
    if module_name == "__main__":
        raise QuadsimError(
            f"the {what} {qualname} was defined in the program that flew it (__main__): to fly it again, "
            "put it in a module of its own"
        )
    try:
        found: Any = importlib.import_module(module_name)
    except Exception as exc:  # whatever the user's module raised while importing
        raise QuadsimError(
            f"the {what} {path} does not import here ({type(exc).__name__}: {str(exc)[:120]}): put its module "
            "on the Python path to fly it again"
        ) from None
    for name in qualname.split("."):
        found = getattr(found, name, None)
    if not inspect.isclass(found) or not all(callable(getattr(found, m, None)) for m in methods):
        raise QuadsimError(f"{path} is not a {what} (a class with {', '.join(methods)})")
    return found
