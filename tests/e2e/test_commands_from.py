"""`run --commands-from FILE.mcap` flies the /quad_cmd_twist of a bag quadsim did not write (rosbags'
rosbag2 writer, MCAP storage, as `ros2 bag record -s mcap` makes them) at its log times, records
the flight, and refuses what it cannot fly with one line.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_commands_from.py."""

from __future__ import annotations

import os

from tests.integration.test_bad_input_files import run_measured
from tests.integration.test_commands_from import _raw_bag


def test_a_bag_of_a_million_commands_flies_in_the_memory_of_a_short_one(tmp_path):
    """Streamed, not loaded: peak memory with 10^6 commands (1 kHz, 1000 s) within 40 MB of 10^3."""
    rss = {}
    for n in (1_000, 1_000_000):
        bag = _raw_bag(tmp_path / f"bag{n}.mcap", range(0, n * 1_000_000, 1_000_000))
        argv = ["run", "--commands-from", str(bag), "--duration", "1", "--cameras", "none", "--no-record"]
        code, err, rss[n] = run_measured(argv, tmp_path, dict(os.environ), timeout_s=300)
        assert code == 0, err
    print(f"\npeak RSS: {rss[1_000]:.0f} MB with 10^3 commands, {rss[1_000_000]:.0f} MB with 10^6")
    assert rss[1_000_000] - rss[1_000] < 40.0, rss
