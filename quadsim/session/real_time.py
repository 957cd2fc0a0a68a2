"""What a run paced to the wall clock does before its first paced step."""

from __future__ import annotations

import gc


def collect_start_up_garbage() -> None:
    """Collect the garbage of start-up now, before real time begins.

    Starting a run (importing PyBullet, numpy, pygame and numba, loading the world, opening the
    window and the recording) leaves about 120,000 young objects. Python's first full collection
    of them came about a second into the flight and took 40-60 ms on a 2-core machine: a hitch
    in the window, and a Twist held that long. Done here it costs the same at a moment nobody
    waits on, and what a run allocates afterwards seldom adds up to another full collection."""
    gc.collect()
