"""The typed run description: a fleet's written and read back, and a bad fleet refused naming
the field.

Its unit tests (in-process, one part at a time); the others are in tests/integration/test_run_description.py."""

from __future__ import annotations

import json

import pytest

from quadsim.sim.description import DescriptionError, RunDescription


def test_a_fleet_description_reads_back_equal_and_refuses_a_bad_fleet():
    """A fleet's description reads back equal to itself (it once held version 2 and wrote 3)."""
    from quadsim import Fleet, FleetVehicle, StartPose

    with Fleet([FleetVehicle("alpha"), FleetVehicle("bravo", start=StartPose(3.0, 0.0))]) as fleet:
        description = fleet.description()
        params = description.to_parameters()
    back = RunDescription.from_parameters(json.loads(json.dumps(params)))
    assert back == description
    assert back.schema_version == 3 and [n for n, _ in back.fleet] == ["alpha", "bravo"]
    assert back.fleet[1][1].config.start == StartPose(3.0, 0.0) and back.config.seed == fleet.config.seed
    for bad, words in (
        ({"fleet": []}, "expected a list of 1 to 100"),
        ({"fleet": [params["fleet"][0], params["fleet"][0]]}, "not a unique ROS name segment"),
        ({"fleet": [{**params["fleet"][0], "name": "../x"}]}, "not a unique ROS name segment"),
        ({"fleet": [{"name": "alpha"}]}, "parameters.fleet[0].config: missing"),
    ):
        with pytest.raises(DescriptionError, match=r"parameters\.fleet"):
            RunDescription.from_parameters({**params, **bad})
        try:
            RunDescription.from_parameters({**params, **bad})
        except DescriptionError as exc:
            assert words in str(exc), (bad, exc)
