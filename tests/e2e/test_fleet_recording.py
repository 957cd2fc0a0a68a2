"""A fleet flown from a fleet file, as a user runs it (`run --fleet`, `check`, `replay --resim`).

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_fleet_recording.py."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from quadsim.recording.flight import load_flight
from tests.helpers.fleets import fleet_toml, vehicle
from tests.helpers.recording import copy_recording
from tests.integration.test_cli import cli
from tests.integration.test_fleet_recording import (
    _decoded,
    fleet_recording,  # noqa: F401 (a fixture)
)

PAIR = """
[[vehicle]]
name = "alpha"
start = [0.0, 0.0, 0.0, 0.0]
input = "script:takeoff"
cameras = ["front", "floor"]
{bravo}"""


BRAVO = fleet_toml(
    vehicle("bravo", (2.5, 0.0, 0.0, 180.0), input="script:climb"),
)


def _front_frames(folder: Path, with_bravo: bool) -> tuple[Path, list]:
    import cv2
    import numpy as np

    (folder / "pair.toml").write_text(PAIR.format(bravo=BRAVO if with_bravo else ""))
    out = cli("run", "--fleet", str(folder / "pair.toml"), "--camera-size", "160x120", "--out", str(folder / "p.mcap"))
    assert out.returncode == 0, out.stderr
    assert "control 240 Hz, cameras alpha (front, floor)" in out.stdout.splitlines()[0]  # whose it records
    flight = load_flight(folder / "p.mcap", "alpha")
    frames = [cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_GRAYSCALE) for _, jpeg in flight.frames["front"]]
    return folder / "p.mcap", frames


def test_a_vehicles_cameras_see_the_other_vehicles_and_only_it_records_them(tmp_path):
    """alpha records its cameras and bravo none; alpha's front camera sees bravo, 2.5 m ahead:
    the same flight without bravo differs only where bravo stands in the picture."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    path, with_bravo = _front_frames(tmp_path / "a", True)
    _, alone = _front_frames(tmp_path / "b", False)
    topics, metadata, _ = _decoded(path)
    cameras = {t for t in topics if "camera" in t}
    assert cameras == {
        "/alpha/quad/front_camera/image_raw/compressed",
        "/alpha/quad/front_camera/camera_info",
        "/alpha/quad/floor_camera/image_raw/compressed",
        "/alpha/quad/floor_camera/camera_info",
    }
    assert topics["/alpha/quad/front_camera/camera_info"][0][1].header.frame_id == "alpha/front_camera_optical"
    assert len(alone) == 180 and len(with_bravo) > 180  # 30 Hz, for 6 s (takeoff) or climb's 10.5 s
    params = json.loads(metadata["quadsim"]["parameters"])
    assert [len(v["cameras"]) for v in params["fleet"]] == [2, 0]
    # 3 s in: bravo has climbed 3 m / 2.5 m ahead, alpha hovers at 2 m (its front camera on the horizon)
    diff = abs(with_bravo[90].astype(int) - alone[90].astype(int)) > 40
    rows, cols = diff.nonzero()
    assert 15 < diff.sum() < 2000, diff.sum()
    assert abs(cols.mean() - 80) < 15 and rows.mean() < 60  # ahead of it, and above the horizon
    assert not (abs(with_bravo[0].astype(int) - alone[0].astype(int)) > 40)[:, :10].any()  # the rest: the same


def _with_parameters(src: Path, dst: Path, edit) -> Path:
    """Copy a recording with its run parameters edited (a crafted or damaged file)."""

    def parameters(name: str, data: dict[str, str]) -> dict[str, str]:
        if name == "quadsim":
            data["parameters"] = json.dumps(edit(json.loads(data["parameters"])))
        return data

    return copy_recording(src, dst, metadata=parameters)


def _set(params: dict, path: str, value) -> dict:
    where = params
    *parents, last = path.split(".")
    for key in parents:
        where = where[int(key)] if isinstance(where, list) else where[key]
    where[int(last) if isinstance(where, list) else last] = value
    return params


CRAFTED = {
    "too_many": (lambda p: {**p, "fleet": p["fleet"] * 40}, "parameters.fleet: expected a list of 1 to 100"),
    "traversing_name": (lambda p: _set(p, "fleet.1.name", "../../bravo"), "not a unique ROS name segment"),
    "not_an_object": (lambda p: _set(p, "fleet.2", "charlie"), "parameters.fleet[2]: expected an object"),
    "traversing_urdf": (
        lambda p: _set(p, "fleet.0.vehicle.urdf", "../../../etc/evil.urdf"),
        "attachment(s) evil.urdf missing",
    ),
    "no_such_vehicle": (lambda p: _set(p, "fleet.2.name", "zulu"), "has no /zulu/quad/pose states"),
    "fleet_left_out": (lambda p: {k: v for k, v in p.items() if k != "fleet"}, "parameters.fleet: expected a list"),
}


@pytest.mark.parametrize("case", list(CRAFTED))
def test_a_crafted_fleet_recording_is_refused_in_one_line_by_every_command(fleet_recording, tmp_path, case):
    """Hostile parameters in a fleet's recording: info and replay still show what is there,
    check and replay --resim refuse it in one line naming why, and nothing is written outside
    the folder asked for."""
    edit, why = CRAFTED[case]
    path = _with_parameters(fleet_recording[0], tmp_path / f"{case}.mcap", edit)
    before = set(Path("/etc").iterdir())
    out = cli("check", str(path))
    assert out.returncode == 2 and "Traceback" not in out.stderr, out.stdout + out.stderr
    assert f"ERROR {path}:" in out.stdout and why in out.stdout, out.stdout
    resim = cli("replay", str(path), "--resim", "--out", str(tmp_path / "resim"))
    assert resim.returncode == 2 and "Traceback" not in resim.stderr and why in resim.stderr, resim.stderr
    assert len(resim.stderr.strip().splitlines()) == 1, resim.stderr
    for argv in (("info", str(path)), ("replay", str(path), "--headless")):
        shown = cli(*argv)
        assert shown.returncode == 0 and "Traceback" not in shown.stderr, (argv, shown.stderr)
    assert set(Path("/etc").iterdir()) == before and not (tmp_path / "resim").exists()
