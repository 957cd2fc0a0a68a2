"""The typed run description: a fleet's written and read back, and a bad fleet refused naming
the field.

Its unit tests (in-process, one part at a time); the others are in tests/integration/test_run_description.py."""

from __future__ import annotations

import json

import pytest

from quadsim.sim.description import DescriptionError, RunDescription


def test_a_fleet_description_reads_back_and_refuses_a_bad_fleet():
    """(Not one test with test_it_reads_back_what_it_wrote over alone and a fleet: a fleet's
    description does not read back equal to itself; it holds schema_version 2 and writes 3.)"""
    from quadsim import Fleet, FleetVehicle, StartPose

    with Fleet([FleetVehicle("alpha"), FleetVehicle("bravo", start=StartPose(3.0, 0.0))]) as fleet:
        params = fleet.description().to_parameters()
    back = RunDescription.from_parameters(json.loads(json.dumps(params)))
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
