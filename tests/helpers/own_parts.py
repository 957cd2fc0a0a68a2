"""Parts of a user's own, importable by the tests and by the re-flights they check: wind models
(quadsim.physics.wind.WindModel). Not a test module."""

from __future__ import annotations

from typing import Any

import numpy as np


class ShearWind:
    """Wind from the west that grows with height: 0.8 m/s per metre, toward +x."""

    def velocity_mps(self, time_s: float, position_m: tuple[float, float, float]) -> tuple[float, float, float]:
        return (0.8 * max(position_m[2], 0.0), 0.0, 0.0)


class GustyWind:
    """A steady 2 m/s toward +y with a gust of random strength every second, drawn from the run's
    generator (so a re-flight meets the same gusts)."""

    def __init__(self, gust_mps: float = 1.5) -> None:
        self.gust_mps = gust_mps
        self._gusts: list[float] = []
        self._rng: np.random.Generator | None = None

    @classmethod
    def from_description(cls, details: dict[str, Any]) -> GustyWind:
        return cls(details["gust_mps"])

    def describe(self) -> dict[str, Any]:
        return {"gust_mps": self.gust_mps}

    def reset(self, rng: np.random.Generator) -> None:
        self._rng, self._gusts = rng, []

    def velocity_mps(self, time_s: float, position_m: tuple[float, float, float]) -> tuple[float, float, float]:
        assert self._rng is not None, "reset(rng) comes first"
        second = int(time_s)
        while len(self._gusts) <= second:
            self._gusts.append(float(self._rng.uniform(-1.0, 1.0)) * self.gust_mps)
        return (0.0, 2.0 + self._gusts[second], 0.0)


class BrokenWind:
    """A model with a bug: no wind at first, then not a number."""

    def velocity_mps(self, time_s: float, position_m: tuple[float, float, float]) -> tuple[float, float, float]:
        return (0.0, 0.0, 0.0) if time_s < 0.5 else (float("nan"), 0.0, 0.0)
