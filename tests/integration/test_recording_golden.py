"""A recording of one vehicle is the same, record for record, as the stored one: the schemas,
channels, every message's bytes and times, the attachments and the run's parameters, apart from
the wall-clock start, the version and where the vehicle's files were (tests/golden/).

tests/golden/takeoff_cameras.mcap was made by the code before a run of one vehicle became a fleet
of one (one plan, one Run, one fan-out for every run), with today's physics (the flight constants
and contacts of issue 36), and made again when the turbulence filter's gain became exact (the same
bits on every machine: docs/reference/determinism.md): the same command still writes it.
Regenerate it (tools/make_regression_recordings.py golden) only when a change to the flight or the
contract is meant, and say why in the commit.

It was flown by PyBullet's step alone (before quadsim had its own step for a vehicle clear of
everything, which agrees with it to about 1e-15 m, not to the bit): the flight is compared with
`--physics pybullet`, and a recording without the setting is read as one flown that way."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from mcap import records
from mcap.stream_reader import StreamReader

from tests.helpers import ROOT

GOLDEN = ROOT / "tests" / "golden" / "takeoff_cameras.mcap"
#: the flight: a take-off in light turbulence with both cameras, small and slow (a small file)
COMMAND = [
    "run",
    "--script",
    "takeoff",
    "--duration",
    "3",
    "--wind",
    "3,45",
    "--turbulence",
    "light",
    "--seed",
    "3",
    "--camera-size",
    "64x48",
    "--camera-hz",
    "10",
]
#: metadata that says when, with which version and from where a run was made, not what it is
NOT_THE_RUN = ("wall_clock_start_utc", "quadsim_version")
PATHS = ("urdf", "vehicle_params", "world")


def _parameters(text: str) -> dict:
    """The run's parameters with its files' paths cut to their names (they say where the clone was)."""
    params = json.loads(text)
    config = params.get("config", {})
    config.setdefault("physics", "pybullet")  # made before the setting: PyBullet's step alone
    for key in PATHS:
        if isinstance(config.get(key), str):
            config[key] = Path(config[key]).name
    return params


def records_of(path: Path) -> list[tuple]:
    """Every record but the indexes, offsets and CRCs (they follow the metadata's length) and the
    chunks' boundaries (a chunk also closes every wall second), as comparable tuples."""
    out: list[tuple] = []
    with path.open("rb") as f:
        for r in StreamReader(f, emit_chunks=False).records:
            if isinstance(r, records.Metadata):
                kept = {k: v for k, v in r.metadata.items() if k not in NOT_THE_RUN}
                if "parameters" in kept:
                    kept["parameters"] = _parameters(kept["parameters"])
                out.append(("metadata", r.name, json.dumps(kept, sort_keys=True)))
            elif isinstance(r, records.Message):
                out.append(("message", r.channel_id, r.sequence, r.log_time, r.publish_time, bytes(r.data)))
            elif isinstance(r, (records.Schema, records.Channel, records.Attachment, records.Header)):
                out.append((type(r).__name__, repr(r)))
    return out


def record(out: Path, *extra: str) -> Path:
    """The golden flight flown again by the command line (with `extra` options) into `out`."""
    done = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), *COMMAND, *extra, "--out", str(out)],
        capture_output=True,
        text=True,
        cwd=out.parent,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    return out


def test_a_recording_of_one_vehicle_is_the_stored_one_record_for_record(tmp_path):
    golden, again = records_of(GOLDEN), records_of(record(tmp_path / "again.mcap", "--physics", "pybullet"))
    assert sum(r[0] == "message" for r in golden) == 1267  # states, commands, both cameras, /rosout, the latched scene
    assert len(again) == len(golden)
    different = [i for i, (a, b) in enumerate(zip(golden, again)) if a != b]
    assert not different, (
        f"{len(different)} records differ, the first: {golden[different[0]]!r:.300} vs {again[different[0]]!r:.300}"
    )


def test_the_comparison_sees_another_flight(tmp_path):
    """It must be able to fail: the same flight with another seed (other gusts, other IMU noise)
    differs in its messages and its parameters, and nowhere else."""
    golden, other = records_of(GOLDEN), records_of(record(tmp_path / "seed4.mcap", "--seed", "4"))
    kinds = {a[0] for a, b in zip(golden, other) if a != b}
    assert kinds == {"message", "metadata"}
