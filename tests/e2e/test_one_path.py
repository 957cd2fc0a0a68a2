"""One run, one path, whatever the number of vehicles: a run of one vehicle, a fleet of one and a
fleet of three are flown by `run`, recorded under each vehicle's names, summarised, read back
vehicle by vehicle, re-flown by `check` and `replay --resim` at 0 m, and described by `info`, by
the same code (quadsim.session.run). The other tests of a run's shape are beside the one-vehicle
tests of the same thing, parametrised over it (tests/integration/test_recording.py, test_cli.py,
test_replay.py, test_teleop.py); what only a fleet has is with what it is about: vehicles that
collide in tests/*/test_contact.py, cameras that see the others in tests/e2e/test_cameras.py,
crafted fleet recordings in tests/e2e/test_damaged_files.py."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest

from quadsim.recording.flight import load_flights
from tests.helpers.fleets import FLEET_OF_ONE, RUNS, run_args
from tests.helpers.mcap import decoded_messages
from tests.integration.test_cli import cli

#: the shapes of a run the tests fly (tests.helpers.fleets.RUNS), and a fleet of one
SHAPES = {**RUNS, "fleet of 1": FLEET_OF_ONE}


def _fly(shape: str, folder: Path) -> tuple[Path, str]:
    out = folder / "run.mcap"
    done = cli(*run_args(SHAPES[shape], folder), "--out", str(out))
    assert done.returncode == 0, done.stderr
    return out, done.stdout


def _topics(path: Path) -> dict[str, list]:
    topics: dict[str, list] = {}
    for channel, _, decoded in decoded_messages(path):
        topics.setdefault(channel.topic, []).append(decoded)
    return topics


@pytest.mark.parametrize("shape", list(SHAPES))
def test_every_run_records_each_vehicle_under_its_names_and_flies_again_at_zero(shape, tmp_path):
    path, stdout = _fly(shape, tmp_path)
    names = tuple(flier.name for flier in SHAPES[shape])
    prefix = {name: f"/{name}" if name else "" for name in names}
    # the summary: one vehicle's whole, a fleet's vehicle by vehicle
    assert "sim time        27.00 s" in stdout
    if names == ("",):
        assert "distance flown  14." in stdout and "final pose" in stdout
    else:
        assert [line.split()[0] for line in stdout.splitlines() if "final x=" in line] == list(names)
    # each vehicle under its names; the shared topics once
    topics = _topics(path)
    for name in names:
        for topic in ("quad/pose", "quad/odom", "quad/imu", "quad/rotor_thrusts", "robot_description"):
            assert f"{prefix[name]}/{topic}" in topics, (name, topic)
        assert len(topics[f"{prefix[name]}/quad/pose"]) == 27 * 60  # the state rate, for each
    assert [len(topics[t]) for t in ("/tf_static", "/world/markers")] == [1, 1]
    frames = {t.child_frame_id for m in topics["/tf"] for t in m.transforms}
    assert frames == {f"{name}/base_link" if name else "base_link" for name in names}
    # the square flown by the first vehicle, whatever else flies
    poses = [m.pose.position for m in topics[f"{prefix[names[0]]}/quad/pose"]]
    path_m = sum(math.dist((a.x, a.y, a.z), (b.x, b.y, b.z)) for a, b in itertools.pairwise(poses))
    assert 13.0 < path_m < 16.0 and math.dist((poses[-1].x, poses[-1].y), (0.0, 0.0)) < 0.2, path_m
    # read back vehicle by vehicle
    flights = load_flights(path)
    assert list(flights) == list(names)
    assert all(len(flights[name].states) == 27 * 60 for name in names)
    # re-flown at 0, by check and by replay --resim; the new recording re-flies too
    fleet = f" (a fleet of {len(names)})" if names != ("",) else ""
    out = cli("check", str(path), "--tolerance-m", "0", "--tolerance-rad", "0")
    assert out.returncode == 0, out.stdout + out.stderr
    assert f"ok    {path}{fleet}: flies again identically (position and attitude as recorded, to the bit)" in out.stdout
    again = tmp_path / "again"
    out = cli("replay", str(path), "--resim", "--out", str(again))
    assert out.returncode == 0, out.stderr
    assert f"{prefix[names[-1]]}/quad/pose position: max 0 m" in out.stdout
    out = cli("check", str(next(again.glob("*.mcap"))), "--tolerance-m", "0", "--tolerance-rad", "0")
    assert out.returncode == 0 and fleet in out.stdout, out.stdout
    info = cli("info", str(path)).stdout
    assert (f"a fleet of {len(names)} vehicles:" in info) == bool(fleet), info
