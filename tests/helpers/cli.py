"""`main.py` as a command runs it: in its own process, from the clone. Not a test module."""

from __future__ import annotations

import resource
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Mapping
from pathlib import Path

from tests.helpers import ROOT

MAIN = ROOT / "main.py"


def run_main(
    *args: object, cwd: Path | None = None, env: Mapping[str, str] | None = None, timeout: float | None = None
) -> subprocess.CompletedProcess[str]:
    """`python main.py ARGS...` to its end, its output captured as text; `env` replaces the
    environment (None: this process's), `cwd` None: this process's."""
    return subprocess.run(
        [sys.executable, str(MAIN), *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=None if env is None else dict(env),
        timeout=timeout,
    )


def bare_env(**extra: str) -> dict[str, str]:
    """An environment with nothing of this one's in it but the system's PATH and the clone on
    PYTHONPATH (what a user's shell in a clone would at least have), plus `extra`."""
    return {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), **extra}


def wait_for_line(proc: subprocess.Popen, text: str | None, count: int) -> tuple[list[str], list[str], list]:
    """Read the process's stdout and stderr (text pipes) as it prints them (a thread each), and
    return once the `count`-th line starting with `text` has come on either (at once for None;
    when the output ends without it): the lists the lines go into, and the reading threads. A
    moment taken from what a process prints, not from a clock, is the same on a busy machine."""
    seen = threading.Event()
    lines: tuple[list[str], list[str]] = ([], [])
    matched, ended = [0], [0]
    lock = threading.Lock()

    def read(stream, into: list[str]) -> None:
        for line in stream:
            into.append(line)
            if text is not None and line.startswith(text):
                with lock:
                    matched[0] += 1
                    if matched[0] == count:
                        seen.set()
        with lock:
            ended[0] += 1
            if ended[0] == 2:
                seen.set()  # the output ended without the line: the run is over

    readers = [
        threading.Thread(target=read, args=(stream, into), daemon=True)
        for stream, into in zip((proc.stdout, proc.stderr), lines)
    ]
    for reader in readers:
        reader.start()
    if text is not None:
        seen.wait(timeout=120)
    return lines[0], lines[1], readers


def file_size_limit(size: int) -> Callable[[], None]:
    """A child's `preexec_fn`: a write past `size` bytes of a file fails (EFBIG), as a full disk's
    do. Give the child `without_caches` too."""

    def limit() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # an error, not the end of the process
        resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))

    return limit


def without_caches(tmp_path: Path) -> dict[str, str]:
    """The environment of a child under `file_size_limit`: Python's bytecode and numba's cache
    are written with writes the limit cuts short, unchecked; the next process would read them cut."""
    return {"PYTHONDONTWRITEBYTECODE": "1", "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
