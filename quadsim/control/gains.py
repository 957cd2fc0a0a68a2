"""Controller gains as data: each airframe's NAME.gains.toml beside its URDF, one table per
controller ([cascade], [seed]), read and checked against the controller's gain fields: a table
or a gain the controllers do not know is refused, naming the file and the table."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any, TypeVar

from quadsim.control import ControllerKind
from quadsim.control import gains_type as gains_of
from quadsim.core.toml_files import near_miss, read_toml, refuse_unknown_keys
from quadsim.errors import ConfigError
from quadsim.vehicle.params import DEFAULT_URDF, VehicleParams

G = TypeVar("G")


def gains_path(vehicle: VehicleParams) -> Path:
    """NAME.gains.toml beside the vehicle's URDF; a vehicle without one flies with the default
    airframe's gains (tune your own by copying that file beside your URDF)."""
    own = vehicle.urdf_path.with_suffix(".gains.toml")
    return own if own.is_file() else DEFAULT_URDF.with_suffix(".gains.toml")


def gain_problem(gains_type: type, value: object) -> str | None:
    """Why `value` cannot be a gain of `gains_type` (None: it can): not a finite number, or
    negative for a controller whose gains and limits are all magnitudes (its NON_NEGATIVE)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return "expected a finite number"
    if value < 0 and getattr(gains_type, "NON_NEGATIVE", False):
        return "expected a number >= 0 (its gains and limits are magnitudes: a negative one flips its loop)"
    return None


def load_gains(vehicle: VehicleParams, section: str, gains_type: type[G], overrides: dict[str, Any] | None = None) -> G:
    """The `[section]` gains of the vehicle's gains file, `overrides` (as a recording holds them)
    replacing any of them. Raises ConfigError naming the file and the gain at fault."""
    path = gains_path(vehicle)
    file = read_toml(path, "controller gains file")
    table = file.get(section)
    if not isinstance(table, dict):
        raise ConfigError(f"{path}: missing the [{section}] table of controller gains")
    _refuse_unknown(path, file, section)
    names = {f.name for f in dataclasses.fields(gains_type)}  # type: ignore[arg-type]
    unknown = sorted(set(overrides or {}) - names)
    if unknown:
        raise ValueError(f"unknown {section} gains: {', '.join(unknown)}")
    values = {**table, **(overrides or {})}
    extra = sorted(set(values) - names)
    missing = sorted(names - set(values))
    if extra or missing:
        said = [_unknown_gains(extra, names)] if extra else []
        said += [f"missing gains {', '.join(missing)}"] if missing else []
        raise ConfigError(f"{path}: [{section}]: " + "; ".join(said))
    for key, value in values.items():
        problem = gain_problem(gains_type, value)
        if problem is not None:
            source = "the gains given" if key in (overrides or {}) else f"{path}: [{section}]"
            raise ConfigError(f"{source}: {key} = {value!r:.40}: {problem}")
    return gains_type(**{k: float(v) for k, v in values.items()})


def _unknown_gains(extra: list[str], names: set[str]) -> str:
    """ "unknown gains a, b", each with the gain it is likely a typo of."""
    said = []
    for key in extra:
        shown = key if key.isidentifier() and len(key) <= 60 else repr(key[:60])  # one line, whatever the key
        near = near_miss(key, sorted(names))
        said.append(f"{shown} (did you mean {near!r}?)" if near is not None else shown)
    return f"unknown gains {', '.join(said)}"


def _refuse_unknown(path: Path, file: dict[str, Any], section: str) -> None:
    """ConfigError for a table of the gains file no controller has, or a gain in another
    controller's table than `section` (checked in full when that controller flies) it has no use for."""
    kinds = tuple(k.value for k in ControllerKind)
    refuse_unknown_keys(
        file,
        kinds,
        str(path),
        top_level=True,
        otherwise=f"a gains file has one table per controller: {', '.join(f'[{k}]' for k in kinds)}",
    )
    for name, table in file.items():
        if name == section:
            continue
        if not isinstance(table, dict):
            raise ConfigError(f"{path}: {name} must be a table of controller gains ([{name}]), got {table!r:.40}")
        names = {f.name for f in dataclasses.fields(gains_of(ControllerKind(name)))}
        extra = [k for k in table if k not in names]
        if extra:
            raise ConfigError(f"{path}: [{name}]: {_unknown_gains(extra, names)}")
