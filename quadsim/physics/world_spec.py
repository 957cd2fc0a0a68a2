"""The world as data: floor and landmarks, read from a TOML file (see assets/worlds/).

Every table refuses a key it does not know, naming the file, the table and the key (a typo such
as [[landmarks]] or `fricton` must not leave a world silently empty or plain)."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from quadsim.assets import asset_path
from quadsim.core.toml_files import read_toml, refuse_unknown_keys
from quadsim.errors import ConfigError

#: the first bytes of the image files a floor texture may be (what PyBullet's loader reads)
_IMAGE_MAGIC = (b"\x89PNG\r\n\x1a\n", b"\xff\xd8\xff", b"BM")


def _is_image(path: Path) -> bool:
    """True when the file starts as a PNG, JPEG or BMP image does (PyBullet only warns, three
    times, on anything else, and flies with an untextured floor)."""
    try:
        with path.open("rb") as fh:
            head = fh.read(8)
    except OSError:
        return False
    return head.startswith(_IMAGE_MAGIC)


DEFAULT_WORLD = asset_path("worlds", "default.toml")
#: the largest world accepted: 10 km (a floor of 1e30 m is a typo, and hangs the renderer)
MAX_FLOOR_SIZE_M = 10_000.0
#: the tables of a world file
WORLD_KEYS = ("floor", "landmark")
#: the keys of its [floor]
FLOOR_KEYS = ("size_m", "texture", "texture_tile_m", "friction")
#: the keys of each of its [[landmark]] tables
LANDMARK_KEYS = ("name", "shape", "position_m", "size_m", "color_rgba", "collision")


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
        raise ConfigError(f"world file {'is a folder' if world_path.is_dir() else 'not found'}: {world_path}")
    table = read_toml(world_path, "world file")
    refuse_unknown_keys(
        table,
        WORLD_KEYS,
        str(world_path),
        top_level=True,
        otherwise="a world file has [floor] and [[landmark]] tables"
        + (f"; is it a fleet file? give it with --fleet {world_path}" if "vehicle" in table else ""),
    )
    floor = _floor(world_path, table.get("floor", {}), texture_required)
    entries = table.get("landmark", [])
    if not isinstance(entries, list):
        raise ConfigError(f"{world_path}: landmark must be an array of tables ([[landmark]]), got {entries!r}")
    landmarks = tuple(_landmark(world_path, i, raw) for i, raw in enumerate(entries))
    return WorldSpec(world_path, floor, landmarks)


def _floor(world_path: Path, value: Any, texture_required: bool) -> FloorSpec:
    where = f"{world_path}: [floor]"
    floor_t = _table(value, where)
    refuse_unknown_keys(floor_t, FLOOR_KEYS, where)
    texture = floor_t.get("texture")
    if texture is not None and (not isinstance(texture, str) or not texture or "\0" in texture):
        raise ConfigError(f"{where} texture must be a file name, got {texture!r}")
    texture_path = (world_path.parent / texture).resolve() if texture else None
    if texture_path is not None and not texture_path.is_file():
        if texture_required:
            raise ConfigError(f"{where} texture not found: {texture_path}")
        texture_path = None
    if texture_path is not None and not _is_image(texture_path):
        raise ConfigError(f"{where} texture {texture_path} is not a PNG, JPEG or BMP image")
    return FloorSpec(
        size_m=_scalar(floor_t, "size_m", 80.0, 1.0, MAX_FLOOR_SIZE_M, where),
        texture_path=texture_path,
        texture_tile_m=_scalar(floor_t, "texture_tile_m", 4.0, 0.01, MAX_FLOOR_SIZE_M, where),
        friction=_scalar(floor_t, "friction", 0.9, 0.0, 10.0, where),
    )


def _landmark(world_path: Path, i: int, raw: Any) -> Landmark:
    entry = _table(raw, f"{world_path}: landmark {i + 1}")
    where = f"{world_path}: landmark {i + 1} ({entry.get('name', '?')})"
    refuse_unknown_keys(entry, LANDMARK_KEYS, where)
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
    return Landmark(
        name=str(entry.get("name", f"landmark_{i + 1}")),
        shape=shape,
        position_m=position,  # type: ignore[arg-type]
        size_m=size,  # type: ignore[arg-type]
        color_rgba=color,  # type: ignore[arg-type]
        collision=collision,
    )
