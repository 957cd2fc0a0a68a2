"""Reading the machine's processes from /proc (Linux), not `ps` (piped, `ps` cuts its lines at 80
columns, and a name past the cut went unseen). Not a test module."""

from __future__ import annotations

import signal
from collections.abc import Iterator
from pathlib import Path

PROC = Path("/proc")


def pids() -> Iterator[int]:
    """Every process's id, as /proc lists them (one may be gone by the time it is read)."""
    for entry in PROC.iterdir():
        if entry.name.isdigit():
            yield int(entry.name)


def status(pid: int) -> dict[str, str]:
    """/proc/PID/status, line by line: {"VmRSS": "1234 kB", "SigBlk": "0000000000004000", ...};
    OSError where the process is gone."""
    fields = {}
    for line in (PROC / str(pid) / "status").read_text().splitlines():
        name, _, value = line.partition(":")
        fields[name] = value.strip()
    return fields


def parent_of(pid: int) -> int:
    """The parent's id, from /proc/PID/stat (the name in it may hold spaces and ')'); OSError
    where the process is gone."""
    stat = (PROC / str(pid) / "stat").read_text()
    return int(stat[stat.rindex(")") + 2 :].split()[1])


def cmdline(pid: int) -> bytes:
    """/proc/PID/cmdline: the arguments, each ended by a NUL; OSError where the process is gone."""
    return (PROC / str(pid) / "cmdline").read_bytes()


def environ(pid: int) -> bytes:
    """/proc/PID/environ: NAME=VALUE entries, each ended by a NUL; OSError where the process is gone."""
    return (PROC / str(pid) / "environ").read_bytes()


SIGTERM_BIT = 1 << (signal.SIGTERM - 1)  # its bit in /proc/PID/status's SigBlk and SigCgt


def takes_signals(pid: int) -> bool:
    """Has quadsim taken the signals: holding them back (SigBlk, the first statement of main.py and
    of quadsim.apps.launch) or handling them (SigCgt, SignalStop)? Python alone does neither for
    SIGTERM. False where the process is gone."""
    try:
        fields = status(pid)
    except OSError:
        return False
    return any(int(fields[name], 16) & SIGTERM_BIT for name in ("SigBlk", "SigCgt") if name in fields)
