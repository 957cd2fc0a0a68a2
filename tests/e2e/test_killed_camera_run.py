"""A camera run killed outright (kill -9) keeps all but its last second or so: the recorder closes
a chunk at every simulated second and at least once a wall second, and holds the run's messages
back for the camera frames of their time only ORDERED_LAG_S at most.

The killed runs are real `run --script square` processes with both cameras at 640x480, beside two
CPU hogs: several times slower than real time, as a camera run is on a busy machine, where a
simulated second takes several wall seconds. They are killed at random moments (half of them in
the run's first simulated second, where the first chunk used to close only at 1 s) and are
synchronised on what they print, never on sleeps: stderr is a terminal, so the progress bar is
redrawn (at most ten times a wall second, and every 1/60 s of simulated time with --realtime)
with the simulated time reached. Once the bar has shown time S, KILL_AFTER_REDRAWS more redraws
mean more than a second of the process's own time has passed (however busy the machine), so a
chunk holding everything up to S, but for the camera frames still being rendered, is on disk.
"""

from __future__ import annotations

import os
import pty
import random
import re
import select
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest
from mcap.reader import make_reader

from quadsim.sensors.pipeline import ORDERED_LAG_S
from tests.helpers import ROOT

TRIALS = int(os.environ.get("QUADSIM_KILL_TRIALS", "6"))
#: redraws at least 0.1 s of wall time apart each: the 10th is a wall second after the first, and
#: the run writes (and so may close a chunk) between any two redraws but one
KILL_AFTER_REDRAWS = 13
BAR = re.compile(rb"sim time \[[#-]+\]\s+([0-9.]+)/")
#: the bar shows tenths of a second, rounded
SHOWN_TO_S = 0.05
STATE_PERIOD_S = 1 / 60


@dataclass
class Killed:
    aimed_s: float  # when (simulated time) the trial waited for
    shown_s: float  # what the bar showed when the count of redraws began
    last_shown_s: float  # what it showed last, just before the kill
    recovered_to_s: float | None  # the last state the recovered file holds (None: nothing recovered)
    recover_said: str


def _run_and_kill(folder: Path, aimed_s: float) -> Killed:
    """A camera run, killed KILL_AFTER_REDRAWS redraws of its progress bar after it showed `aimed_s`."""
    folder.mkdir(parents=True)
    out = folder / "killed.mcap"
    command = [sys.executable, str(ROOT / "main.py"), "run", "--script", "square", "--realtime", "--duration", "4"]
    command += ["--camera-size", "640x480"]
    ours, theirs = pty.openpty()
    proc = subprocess.Popen(
        [*command, "--out", str(out)],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=theirs,
        cwd=folder,
        env={**os.environ, "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy"},
    )
    os.close(theirs)
    shown = last = None
    redraws = 0
    seen = b""
    deadline = time.monotonic() + 300  # a guard against a hang, not a synchronisation
    try:
        while time.monotonic() < deadline:
            ready, _, _ = select.select([ours], [], [], 5.0)
            if not ready:
                continue
            try:
                data = os.read(ours, 4096)
            except OSError:  # the run ended (EIO): it was never killed
                break
            if not data:
                break
            seen += data
            end = 0
            for redraw in BAR.finditer(seen):  # a redraw cut in two by a read matches once whole
                end = redraw.end()
                last = float(redraw[1])
                if shown is None and last >= aimed_s:
                    shown = last
                elif shown is not None:
                    redraws += 1
            seen = seen[end:]
            if shown is not None and redraws >= KILL_AFTER_REDRAWS:
                proc.send_signal(signal.SIGKILL)
                break
    finally:
        proc.kill()
        proc.wait()
        os.close(ours)
    assert shown is not None and redraws >= KILL_AFTER_REDRAWS, f"the run ended before it was killed ({last})"
    result = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "recover", str(out)], capture_output=True, text=True, cwd=folder
    )
    recovered = out.with_name("killed.recovered.mcap")
    end = None
    if result.returncode == 0:
        with open(recovered, "rb") as fh:
            poses = [m.log_time for _, _, m in make_reader(fh).iter_messages(topics=["/quad/pose"])]
        end = poses[-1] / 1e9 if poses else None
    return Killed(aimed_s, shown, last, end, result.stdout + result.stderr)


@pytest.fixture(scope="module")
def killed(tmp_path_factory) -> list[Killed]:
    base = tmp_path_factory.mktemp("killed")
    rng = random.Random(20261127)
    aims = [round(rng.uniform(0.1, 0.9) if i % 2 else rng.uniform(0.9, 2.0), 1) for i in range(TRIALS)]
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    try:
        with ThreadPoolExecutor(max_workers=2) as pool:
            results = list(pool.map(lambda ia: _run_and_kill(base / f"t{ia[0]}", ia[1]), enumerate(aims)))
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    for k in results:
        print(f"\nkilled at {k.last_shown_s} s (counted from {k.shown_s} s): recovered up to {k.recovered_to_s} s")
    return results


@pytest.mark.slow
def test_a_killed_camera_run_keeps_all_but_its_last_second(killed):
    """What the bar had shown more than a wall second before the kill is in the recovered file,
    but for the camera frames still being rendered then: however slow the run (a simulated
    second can take several wall seconds with cameras, on a busy machine), and even when it is
    killed in its first simulated second."""
    for k in killed:
        assert k.recovered_to_s is not None, (
            f"nothing recovered from a run killed at {k.last_shown_s} s: {k.recover_said}"
        )
        assert k.recovered_to_s >= k.shown_s - SHOWN_TO_S - ORDERED_LAG_S - STATE_PERIOD_S, k
        assert k.recovered_to_s <= k.last_shown_s + 1.0, k  # (what it recovered is what was flown)
