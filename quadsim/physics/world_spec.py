"""The world as data: floor and landmarks, read from a TOML file (see assets/worlds/)."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from quadsim.assets import asset_path
from quadsim.core.toml_compat import tomllib
from quadsim.errors import ConfigError

DEFAULT_WORLD = asset_path("worlds", "default.toml")


class Shape(enum.Enum):
    BOX = "box"
    CYLINDER = "cylinder"
    SPHERE = "sphere"


@dataclass(frozen=True)
class Landmark:
    name: str
    shape: Shape
    position_m: tuple[float, float, float]
    size_m: tuple[float, float, float]  # box: full extents; cylinder: radius, radius, height; sphere: radius
    color_rgba: tuple[float, float, float, float]
    collision: bool = True


@dataclass(frozen=True)
class FloorSpec:
    size_m: float
    texture_path: Path | None
    texture_tile_m: float
    friction: float


@dataclass(frozen=True)
class WorldSpec:
    path: Path
    floor: FloorSpec
    landmarks: tuple[Landmark, ...]


def _vector(entry: dict[str, Any], key: str, n: int, where: str) -> tuple[float, ...]:
    value = entry.get(key)
    if (
        not isinstance(value, list)
        or len(value) != n
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    ):
        raise ConfigError(f"{where}: {key} must be a list of {n} numbers, got {value!r}")
    return tuple(float(v) for v in value)


def load_world(path: Path | str | None = None, texture_required: bool = True) -> WorldSpec:
    """Read and validate a world file; raises ConfigError naming the file and entry.

    Without `texture_required`, a missing floor texture leaves the floor plain (re-simulating
    a recording, whose attachments hold the world file but not its texture)."""
    world_path = Path(path) if path is not None else DEFAULT_WORLD
    if not world_path.is_file():
        raise ConfigError(f"world file not found: {world_path}")
    try:
        with world_path.open("rb") as fh:
            table = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{world_path}: not valid TOML ({exc})") from None
    floor_t = table.get("floor", {})
    texture = floor_t.get("texture")
    texture_path = (world_path.parent / texture).resolve() if texture else None
    if texture_path is not None and not texture_path.is_file():
        if texture_required:
            raise ConfigError(f"{world_path}: [floor] texture not found: {texture_path}")
        texture_path = None
    floor = FloorSpec(
        size_m=float(floor_t.get("size_m", 80.0)),
        texture_path=texture_path,
        texture_tile_m=float(floor_t.get("texture_tile_m", 4.0)),
        friction=float(floor_t.get("friction", 0.9)),
    )
    if floor.size_m <= 0 or floor.texture_tile_m <= 0:
        raise ConfigError(f"{world_path}: [floor] size_m and texture_tile_m must be > 0")
    landmarks = []
    for i, entry in enumerate(table.get("landmark", [])):
        where = f"{world_path}: landmark {i + 1} ({entry.get('name', '?')})"
        try:
            shape = Shape(entry.get("shape"))
        except ValueError:
            raise ConfigError(f"{where}: shape must be one of {[s.value for s in Shape]}") from None
        size = _vector(entry, "size_m", 3, where)
        if min(size) <= 0:
            raise ConfigError(f"{where}: size_m must be > 0")
        landmarks.append(
            Landmark(
                name=str(entry.get("name", f"landmark_{i + 1}")),
                shape=shape,
                position_m=_vector(entry, "position_m", 3, where),  # type: ignore[arg-type]
                size_m=size,  # type: ignore[arg-type]
                color_rgba=_vector(entry, "color_rgba", 4, where),  # type: ignore[arg-type]
                collision=bool(entry.get("collision", True)),
            )
        )
    return WorldSpec(world_path, floor, tuple(landmarks))
