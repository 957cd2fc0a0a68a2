"""Import pybullet without the "pybullet build time" banner its C code prints on import."""

from __future__ import annotations

import ctypes
import os
import sys


def _import_quietly():
    try:
        libc = ctypes.CDLL(None)
        saved = (os.dup(1), os.dup(2))
    except (OSError, AttributeError):  # no POSIX libc: accept the banner
        import pybullet

        return pybullet
    sys.stdout.flush()
    sys.stderr.flush()
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.dup2(devnull, 2)
    try:
        import pybullet

        libc.fflush(None)  # whatever sits in C's buffers goes to /dev/null too
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        os.close(saved[0])
        os.close(saved[1])
        os.close(devnull)
    return pybullet


pb = _import_quietly()
