"""Compiled arithmetic where numba is installed (with quadsim, where it has wheels; the `fast`
extra installs it too), plain Python where it is not, or where QUADSIM_FLIGHT_CORE=python says so.

`jit` marks a function of floats, tuples of floats and float arrays as compilable: with numba,
it is compiled to machine code on its first call (and cached on disk); without numba, or with
NUMBA_DISABLE_JIT=1, it is the same Python function. Both give the same results to the bit:
the functions use only arithmetic that numba and CPython round alike (no `math.hypot`, whose
libm and CPython versions differ in the last bit), and numba does not fuse a multiply and an
add (tests/unit/test_compiled.py checks a flight both ways).

`floats` holds a function's constants or state: a float array for compiled code, a list for
Python (a list is faster to index from Python, an array from compiled code).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import inspect
import os
import types
from collections.abc import Callable, Iterable, MutableSequence, Sequence
from pathlib import Path
from typing import Any, TypeVar

from quadsim.core.invocation import install_extra

F = TypeVar("F", bound=Callable[..., Any])
#: what compiled functions take for constants (a float64 array, or a list: `floats`)
Floats = Sequence[float]
#: what they write into (the same)
MutableFloats = MutableSequence[float]

#: the environment variable that chooses the flight core: `python` flies it as plain Python and
#: does not import numba at all (importing numba and loading its cached code costs a process about
#: 0.7 CPU-s, more than a short run's flight gains from it: docs/reference/performance.md);
#: `compiled` or unset: compiled wherever numba imports
CHOICE_VARIABLE = "QUADSIM_FLIGHT_CORE"
#: the value of CHOICE_VARIABLE this process started with ("" when unset)
CHOICE = os.environ.get(CHOICE_VARIABLE, "").strip().lower()

numba: Any = None
#: why numba, though installed, did not import (None: it imported, or it is not installed)
NUMBA_PROBLEM: str | None = None
if CHOICE != "python":
    try:
        import numba
    except Exception as exc:  # numba is not installed, or is broken: everything runs as Python
        numba = None
        if not (isinstance(exc, ImportError) and exc.name == "numba"):
            NUMBA_PROBLEM = f"{type(exc).__name__}: {exc}"

#: numba's version when it is installed, else None
NUMBA_VERSION: str | None = None if numba is None else str(numba.__version__)
#: True when `jit` compiles (numba is installed and imported, and NUMBA_DISABLE_JIT is not set)
COMPILED: bool = numba is not None and not numba.config.DISABLE_JIT


def status() -> str:
    """Whether the flight core's arithmetic is compiled in this process, or why not (one line)."""
    if COMPILED:
        said = f"flight core compiled by numba {NUMBA_VERSION}"
    elif CHOICE == "python":
        said = f"flight core as plain Python: {CHOICE_VARIABLE}=python is set"
    elif NUMBA_VERSION is not None:
        said = "flight core as plain Python: NUMBA_DISABLE_JIT is set"
    elif NUMBA_PROBLEM is not None:
        said = f"flight core as plain Python: numba is installed but did not import ({NUMBA_PROBLEM})"
    else:
        said = f"flight core as plain Python: {install_extra('fast')} (numba) to compile it"
    if CHOICE not in ("", "python", "compiled"):
        said += f" ({CHOICE_VARIABLE}={CHOICE} is neither python nor compiled: ignored)"
    return said


#: every module of the package with compiled functions (tests/unit/test_compiled.py checks the list)
FLIGHT_CORE = (
    "core/rigid_body.py",
    "physics/base_link.py",
    "physics/free_flight.py",
    "vehicle/aero.py",
    "vehicle/motors.py",
    "vehicle/mixer.py",
    "vehicle/wrench.py",
    "control/cascade_step.py",
    "control/landing.py",
    "sensors/imu.py",
    "sim/clear_flight.py",
    "envs/hover_numbers.py",
)
_PACKAGE = Path(__file__).resolve().parent.parent
_digest: str | None = None


def flight_core_digest() -> str:
    """A digest of the source of every module in FLIGHT_CORE, the same whatever was imported first."""
    global _digest
    if _digest is None:
        digest = hashlib.sha256()
        for name in FLIGHT_CORE:
            with contextlib.suppress(OSError):  # installed without its sources: nothing to edit
                digest.update((_PACKAGE / name).read_bytes())
        _digest = digest.hexdigest()[:12]
    return _digest


#: how long a first compile of the flight core takes, as a user is told (measured: 3 s on an idle
#: 2-core machine, 38 s at load 8)
FIRST_COMPILE = "a few seconds, up to a minute on a busy machine"


def will_compile() -> bool:
    """Whether building a vehicle now compiles the flight core (numba, no cache of this version of
    it yet: the first run after an install or an upgrade), so that a start-up can say so first."""
    if not COMPILED:
        return False
    digest = flight_core_digest()
    chosen = os.environ.get("NUMBA_CACHE_DIR")
    if chosen:  # numba then keeps its cache there, and only there
        places = [Path(chosen)]
    else:  # next to the sources, or in the user's cache where those cannot be written
        places = [_PACKAGE / name.rsplit("/", 1)[0] / "__pycache__" for name in FLIGHT_CORE]
        places.append(Path.home() / ".cache" / "numba")
    for place in places:
        with contextlib.suppress(OSError):
            if next(place.rglob(f"*_{digest}-*.nbi"), None) is not None:
                return False
    return True


def jit(function: F) -> F:
    """`function` compiled by numba (nopython, cached on disk) when it can be, else itself.

    numba's cache checks only the compiled function's own file, yet the code it keeps has the
    compiled functions it calls built in: after an edit to one of those, it would run the old
    code. So the cache's name carries a digest of every module of the flight core (and of the
    function's own file, if it is elsewhere): an edit to any of them compiles again."""
    if not COMPILED:
        return function
    digest = flight_core_digest()
    source = Path(inspect.getsourcefile(function) or "?").resolve()
    if source not in {_PACKAGE / name for name in FLIGHT_CORE}:
        with contextlib.suppress(OSError):
            digest = hashlib.sha256(digest.encode() + source.read_bytes()).hexdigest()[:12]
    named = types.FunctionType(
        function.__code__, function.__globals__, function.__name__, function.__defaults__, function.__closure__
    )
    named.__qualname__ = f"{function.__qualname__}_{digest}"
    named.__doc__, named.__module__ = function.__doc__, function.__module__
    try:
        compiled: F = numba.njit(cache=True, error_model="python")(named)
    except RuntimeError:  # nowhere to write the cache (a read-only install and home): compile each run
        compiled = numba.njit(error_model="python")(named)
    return compiled


def python_of(function: F) -> F:
    """The Python function a `jit` function was compiled from (itself where nothing compiles):
    the same arithmetic, for callers in Python, where a compiled call's dispatch costs more than
    the work."""
    return getattr(function, "py_func", function)


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


def float_tuple(values: Iterable[float]) -> Any:
    """`values` as a tuple of floats, as compiled functions take them, whatever sequence of numbers
    they came as (a list, integers)."""
    return tuple(float(v) for v in values)


def typed_list(items: Iterable[Any]) -> Any:
    """`items` (all of one type) as a list compiled functions take: numba's typed List when they
    are compiled (one compile whatever its length, where a tuple's length is part of its type),
    a list when they are Python. Made and changed (`set_item`) by compiled functions of its own,
    cached like the rest: a typed List's own methods, called from Python, compile anew in every
    process (0.9 s)."""
    listed = list(items)
    if not COMPILED:
        return listed
    make, append, _ = _list_functions()
    typed = make(listed[0])
    for item in listed[1:]:
        append(typed, item)
    return typed


def set_item(items: Any, index: int, item: Any) -> None:
    """items[index] = item, for a `typed_list`."""
    if COMPILED:
        _list_functions()[2](items, index, item)
    else:
        items[index] = item


_List: Any = None  # numba.typed.List, imported with the first typed list (25 ms; only fleets need it)


def _typed_list_of(item: Any) -> Any:
    items = _List()
    items.append(item)
    return items


def _append_to(items: Any, item: Any) -> None:
    items.append(item)


def _set_item_of(items: Any, index: int, item: Any) -> None:
    items[index] = item


@functools.cache
def _list_functions() -> tuple[Callable[..., Any], Callable[..., Any], Callable[..., Any]]:
    """The compiled functions that make, append to and change a typed list, once numba.typed is in."""
    global _List
    from numba.typed import List

    _List = List
    return jit(_typed_list_of), jit(_append_to), jit(_set_item_of)


def table(rows: Iterable[Iterable[float]]) -> Any:
    """Rows of floats as the flight core's functions index them (`rows[i][j]`): a 2-D float64
    array when they are compiled, a list of lists when they are Python."""
    if COMPILED:
        import numpy as np

        return np.array([[float(v) for v in row] for row in rows], dtype=np.float64)
    return [[float(v) for v in row] for row in rows]
