"""The world as data: floor and landmarks, read from a TOML file (see assets/worlds/)."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from quadsim.assets import asset_path
from quadsim.core.toml_files import read_toml
from quadsim.errors import ConfigError

DEFAULT_WORLD = asset_path("worlds", "default.toml")
#: the largest world accepted: 10 km (a floor of 1e30 m is a typo, and hangs the renderer)
MAX_FLOOR_SIZE_M = 10_000.0


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


def _scalar(table: dict[str, Any], key: str, default: float, low: float, high: float, where: str) -> float:
    value = table.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{where}: {key} must be a number, got {value!r}")
    if not low <= value <= high:
        raise ConfigError(f"{where}: {key} = {value} is outside the sensible range [{low:g}, {high:g}]")
    return float(value)


def _table(value: Any, where: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ConfigError(f"{where} must be a table, got {value!r}")
    return value


def load_world(path: Path | str | None = None, texture_required: bool = True) -> WorldSpec:
    """Read and validate a world file; raises ConfigError naming the file and entry.

    Without `texture_required`, a missing floor texture leaves the floor plain (re-simulating
    a recording, whose attachments hold the world file but not its texture)."""
    world_path = Path(path) if path is not None else DEFAULT_WORLD
    if not world_path.is_file():
        raise ConfigError(f"world file not found: {world_path}")
    table = read_toml(world_path, "world file")
    floor_t = _table(table.get("floor", {}), f"{world_path}: [floor]")
    texture = floor_t.get("texture")
    if texture is not None and (not isinstance(texture, str) or not texture or "\0" in texture):
        raise ConfigError(f"{world_path}: [floor] texture must be a file name, got {texture!r}")
    texture_path = (world_path.parent / texture).resolve() if texture else None
    if texture_path is not None and not texture_path.is_file():
        if texture_required:
            raise ConfigError(f"{world_path}: [floor] texture not found: {texture_path}")
        texture_path = None
    where = f"{world_path}: [floor]"
    floor = FloorSpec(
        size_m=_scalar(floor_t, "size_m", 80.0, 1.0, MAX_FLOOR_SIZE_M, where),
        texture_path=texture_path,
        texture_tile_m=_scalar(floor_t, "texture_tile_m", 4.0, 0.01, MAX_FLOOR_SIZE_M, where),
        friction=_scalar(floor_t, "friction", 0.9, 0.0, 10.0, where),
    )
    landmarks = []
    entries = table.get("landmark", [])
    if not isinstance(entries, list):
        raise ConfigError(f"{world_path}: landmark must be an array of tables ([[landmark]]), got {entries!r}")
    for i, raw in enumerate(entries):
        entry = _table(raw, f"{world_path}: landmark {i + 1}")
        where = f"{world_path}: landmark {i + 1} ({entry.get('name', '?')})"
        try:
            shape = Shape(entry.get("shape"))
        except (ValueError, TypeError):
            raise ConfigError(f"{where}: shape must be one of {[s.value for s in Shape]}") from None
        size = _vector(entry, "size_m", 3, where)
        if min(size) <= 0 or max(size) > MAX_FLOOR_SIZE_M:
            raise ConfigError(f"{where}: size_m must be > 0 and at most {MAX_FLOOR_SIZE_M:g} m")
        position = _vector(entry, "position_m", 3, where)
        if max(abs(v) for v in position) > MAX_FLOOR_SIZE_M:
            raise ConfigError(f"{where}: position_m must be within {MAX_FLOOR_SIZE_M:g} m of the origin")
        color = _vector(entry, "color_rgba", 4, where)
        if not all(0.0 <= c <= 1.0 for c in color):
            raise ConfigError(f"{where}: color_rgba values must be within 0..1")
        collision = entry.get("collision", True)
        if not isinstance(collision, bool):
            raise ConfigError(f"{where}: collision must be true or false, got {collision!r}")
        landmarks.append(
            Landmark(
                name=str(entry.get("name", f"landmark_{i + 1}")),
                shape=shape,
                position_m=position,  # type: ignore[arg-type]
                size_m=size,  # type: ignore[arg-type]
                color_rgba=color,  # type: ignore[arg-type]
                collision=collision,
            )
        )
    return WorldSpec(world_path, floor, tuple(landmarks))
