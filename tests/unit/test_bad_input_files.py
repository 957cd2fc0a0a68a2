"""Crafted sweep, world and vehicle-parameter files through the real command line.

Its unit tests (in-process, one part at a time); the others are in tests/integration/test_bad_input_files.py."""

from __future__ import annotations

from pathlib import Path

import pytest


def test_a_deep_joystick_mapping_is_refused_naming_the_file(tmp_path: Path) -> None:
    """Read when a pad appears (not on the command line): the same bounded reader."""
    from quadsim import ConfigError
    from quadsim.drivers.joystick import load_mapping

    path = tmp_path / "pad.toml"
    path.write_text("deadzone = " + "{a = " * 200 + "1" + "}" * 200)
    with pytest.raises(ConfigError, match=f"{path}: .*nested deeper than 16 levels"):
        load_mapping(path)
