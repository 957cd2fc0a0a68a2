"""Writing a file whole or not at all: written beside it under a hidden name, then given its name.
A full disk, an error or Ctrl-C leaves nothing behind (a retry is not refused by a cut file), and
another process reading it never sees half of it. A file the user named is never written over a
file that is there (or appeared meanwhile); a cache's file replaces its twin."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

from quadsim.errors import QuadsimError


def write_whole(out: Path, write: Callable[[BinaryIO], object], exists: str | None = None) -> None:
    """`write(file)` fills `out`. With `exists` (what to say when it is there), `out` must not
    exist; without, it is replaced. An OSError (the disk full, a folder that cannot hold it) is
    raised as it came, with nothing left."""
    if exists is not None and out.exists():
        raise QuadsimError(exists)
    folder = out.parent if str(out.parent) else Path(".")
    fd, tmp_name = tempfile.mkstemp(prefix=f".{out.name[:200]}.", suffix=".partial", dir=folder)
    tmp = Path(tmp_name)
    try:
        mask = os.umask(0)
        os.umask(mask)
        os.fchmod(fd, 0o666 & ~mask)  # as a file made by open() would be
        with os.fdopen(fd, "wb") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        if exists is None:
            os.replace(tmp, out)
            return
        try:
            os.link(tmp, out)
        except FileExistsError:
            raise QuadsimError(exists) from None
        except OSError:  # a file system without hard links
            if out.exists():
                raise QuadsimError(exists) from None
            os.replace(tmp, out)
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()
