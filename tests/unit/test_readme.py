"""The README and the docs tell the truth: their example output is what the code prints.

Its unit tests (in-process, one part at a time); the others are in tests/integration/test_readme.py."""

from __future__ import annotations

from tests.helpers import ROOT
from tests.integration.test_readme import README


def test_what_the_readme_says_of_the_example_fleet_holds():
    """The README said `fly --fleet` flies one of the example's vehicles from the keyboard: the
    example has none (`run --fleet` refuses one, and the example is what `run --fleet` flies).
    It says which input a vehicle needs and which of the example's to change."""
    from quadsim.core.toml_files import read_toml

    example = read_toml(ROOT / "examples" / "fleet.toml", "fleet file")
    inputs = {vehicle["name"]: vehicle["input"] for vehicle in example["vehicle"]}
    assert not {"keyboard", "gamepad"} & set(inputs.values())  # so the README must say what to set
    said = " ".join(README.split("`fly --fleet", 1)[1].split("\n\n", 1)[0].split())
    assert 'whose input is `"keyboard"` or `"gamepad"`' in said
    assert 'set `delta`\'s input to `"keyboard"`' in said and inputs["delta"] == "idle"
