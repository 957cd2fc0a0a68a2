"""Fleet files as the tests write them: `fleet_toml(vehicle(...), ...)`. Not a test module."""

from __future__ import annotations

import json
from collections.abc import Sequence


def vehicle(
    name: str,
    start: Sequence[float],
    *,
    airframe: str | None = None,
    input: str | None = None,
    cameras: Sequence[str] | None = None,
) -> str:
    """One [[vehicle]] table: its name, airframe, start pose (x, y, z in m, heading in deg), input
    and cameras, in that order; a key left None is not written (the fleet file's default)."""
    lines = ["[[vehicle]]", f"name = {json.dumps(name)}"]
    if airframe is not None:
        lines.append(f"airframe = {json.dumps(airframe)}")
    lines.append(f"start = [{', '.join(repr(float(v)) for v in start)}]")
    if input is not None:
        lines.append(f"input = {json.dumps(input)}")
    if cameras is not None:
        lines.append(f"cameras = {json.dumps(list(cameras))}")
    return "\n".join(lines) + "\n"


def fleet_toml(*vehicles: str) -> str:
    """A fleet file of `vehicles` (vehicle()'s tables), a blank line before each."""
    return "".join(f"\n{table}" for table in vehicles)
