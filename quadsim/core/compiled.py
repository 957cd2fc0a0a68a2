"""Compiled arithmetic where numba is installed (the `fast` extra), plain Python where it is not.

`jit` marks a function of floats, tuples of floats and float arrays as compilable: with numba,
it is compiled to machine code on its first call (and cached on disk); without numba, or with
NUMBA_DISABLE_JIT=1, it is the same Python function. Both give the same results to the bit:
the functions use only arithmetic that numba and CPython round alike (no `math.hypot`, whose
libm and CPython versions differ in the last bit), and numba does not fuse a multiply and an
add (tests/test_compiled.py checks a flight both ways).

`floats` holds a function's constants or state: a float array for compiled code, a list for
Python (a list is faster to index from Python, an array from compiled code).
"""

from __future__ import annotations

import contextlib
import hashlib
import inspect
import types
from collections.abc import Callable, Iterable, MutableSequence, Sequence
from pathlib import Path
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])
#: what compiled functions take for constants (a float64 array, or a list: `floats`)
Floats = Sequence[float]
#: what they write into (the same)
MutableFloats = MutableSequence[float]

numba: Any
try:
    import numba
except ImportError:  # the `fast` extra is not installed: everything runs as Python
    numba = None

#: numba's version when it is installed, else None
NUMBA_VERSION: str | None = None if numba is None else str(numba.__version__)
#: True when `jit` compiles (numba is installed and NUMBA_DISABLE_JIT is not set)
COMPILED: bool = numba is not None and not numba.config.DISABLE_JIT

#: what `quadsim bench` says when numba is not installed
MISSING = "the flight core runs as plain Python: pip install 'quadsim[fast]' (numba) to compile it"


#: the source files of every function `jit` has compiled so far, in order
_sources: list[str] = []


def jit(function: F) -> F:
    """`function` compiled by numba (nopython, cached on disk) when it can be, else itself.

    numba's cache checks only the compiled function's own file, yet the code it keeps has the
    compiled functions it calls built in: after an edit to one of those, it would run the old
    code. So the cache's name carries a digest of the source of every compiled function seen so
    far (those it can call are imported, so compiled, before it): an edit anywhere in them
    compiles again."""
    if not COMPILED:
        return function
    source = inspect.getsourcefile(function) or "?"
    if source not in _sources:
        _sources.append(source)
    digest = hashlib.sha256()
    for path in _sources:
        with contextlib.suppress(OSError):
            digest.update(Path(path).read_bytes())
    named = types.FunctionType(
        function.__code__, function.__globals__, function.__name__, function.__defaults__, function.__closure__
    )
    named.__qualname__ = f"{function.__qualname__}_{digest.hexdigest()[:12]}"
    named.__doc__, named.__module__ = function.__doc__, function.__module__
    try:
        compiled: F = numba.njit(cache=True, error_model="python")(named)
    except RuntimeError:  # nowhere to write the cache (a read-only install and home): compile each run
        compiled = numba.njit(error_model="python")(named)
    return compiled


def specialize(function: F, *sample: Any) -> F:
    """`function` made for arguments of the types of `sample` (compiled now, or loaded from the
    cache): called with exactly those types, it skips numba's type dispatch, about half a
    microsecond a call with a dozen arguments. Arguments of another type raise TypeError or
    ValueError; `function` itself still takes them. Without numba, `function` itself."""
    if not COMPILED:
        return function
    dispatcher: Any = function
    entry: F = dispatcher.compile(tuple(numba.typeof(value) for value in sample))
    return entry


def floats(values: Iterable[float]) -> Any:
    """`values` as the container the flight core's functions index: a float64 array when they
    are compiled, a list of floats when they are Python."""
    if COMPILED:
        import numpy as np

        return np.array([float(v) for v in values], dtype=np.float64)
    return [float(v) for v in values]


def table(rows: Iterable[Iterable[float]]) -> Any:
    """Rows of floats as the flight core's functions index them (`rows[i][j]`): a 2-D float64
    array when they are compiled, a list of lists when they are Python."""
    if COMPILED:
        import numpy as np

        return np.array([[float(v) for v in row] for row in rows], dtype=np.float64)
    return [[float(v) for v in row] for row in rows]
