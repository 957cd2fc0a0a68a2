"""Import pybullet without the "pybullet build time" banner its C code prints on import, and
silence what its C plugins print (the EGL renderer's GL strings) where that is wanted."""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from collections.abc import Iterator


@contextlib.contextmanager
def c_output_silenced() -> Iterator[None]:
    """File descriptors 1 and 2 go to /dev/null while inside (what C code prints, not Python)."""
    try:
        libc = ctypes.CDLL(None)
        saved = (os.dup(1), os.dup(2))
    except (OSError, AttributeError):
        yield
        return
    sys.stdout.flush()
    sys.stderr.flush()
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.dup2(devnull, 2)
    try:
        yield
    finally:
        libc.fflush(None)
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        os.close(saved[0])
        os.close(saved[1])
        os.close(devnull)


with c_output_silenced():
    import pybullet as pb  # noqa: F401 - what this module is imported for
