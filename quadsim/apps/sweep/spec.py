"""A sweep file (TOML) and the runs it stands for.

    name = "wind"                        # optional; default: the file's name
    scenarios = ["hover", "square"]      # built-in names, .qscript paths or fleet .toml files
                                         # (paths relative to this file)
    airframes = ["quad"]                 # shipped presets (quad, hexa, crazyflie); default: quad
    seeds = 3                            # runs per combination, seeded 0, 1, 2 (default 1)
    duration_s = 20.0                    # optional; default: each scenario's own duration
    wind = ["0,0", "3,90", "5,90"]       # SPEED,FROM_DEG as --wind takes it; default: no wind
    turbulence = ["none", "moderate"]    # as --turbulence gives it; default: none

    [controllers.cascade]                # a name of your choice; kind = cascade or seed
    kind = "cascade"
    [controllers.cascade_soft]
    kind = "cascade"
    gains = { velocity_p_xy_per_s = 2.0 }  # replaces the named gains of that controller

    [limits]                             # a run fails when a metric is above its limit
    max_tilt_deg = 45
    crashes = 0

The runs are the product scenarios x airframes x controllers x wind x turbulence x seeds, in
that order; each has a key naming its values, by which `--resume` recognises it.

A fleet file as a scenario flies its whole fleet in each run (its vehicles on their scripts, or
idle), swept over wind, turbulence and seeds: its vehicles name their own airframes and
controllers, so a sweep with a fleet leaves `airframes` and `controllers` out. Its row holds each
metric's largest over the vehicles (no vehicle beyond a limit, or the run fails, naming which).
"""

from __future__ import annotations

import collections
import hashlib
import itertools
import json
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from quadsim.control import ControllerKind, gains_type
from quadsim.control.gains import gain_problem
from quadsim.core.toml_files import near_miss, read_toml, refuse_unknown_keys
from quadsim.errors import ConfigError
from quadsim.physics.wind import Turbulence, wind_from_text

if TYPE_CHECKING:
    from quadsim.drivers.scripted import Script

#: the keys a sweep file may have at its top level
KNOWN_KEYS = {"name", "scenarios", "airframes", "seeds", "duration_s", "wind", "turbulence", "controllers", "limits"}
#: the most runs one sweep file may stand for (a typo in `seeds` should not queue a million runs)
MAX_RUNS = 100_000
#: the most values one axis may list (checked before anything else looks at them)
MAX_VALUES = 1_000
#: the longest a run may fly (duration_s, or a scenario's own length when duration_s is not given)
MAX_RUN_S = 3600.0
#: a sweep's name becomes a folder name: one plain name, never a path
NAME_PATTERN = re.compile(r"\w[\w .+-]{0,99}")


def is_fleet_scenario(scenario: str) -> bool:
    """A scenario given as a fleet file (NAME.toml), not a script."""
    return scenario.endswith(".toml")


@dataclass(frozen=True)
class ControllerChoice:
    """A named controller: its kind and the gains that replace its defaults."""

    name: str
    kind: ControllerKind
    gains: tuple[tuple[str, float], ...] = ()


@dataclass(frozen=True)
class RunSpec:
    """One run of a sweep: everything it takes to fly it (plain data, picklable)."""

    index: int
    scenario: str  # a built-in name or an absolute script path
    airframe: str
    controller: ControllerChoice
    wind: str
    turbulence: str
    seed: int
    duration_s: float | None
    #: the simulated time it flies, s (its duration, else its scenario's length): the largest runs
    #: are handed out first, so that no worker is left with a long run at the end
    sim_s: float = 0.0
    #: a digest of what the scenario flies (a script's text; a fleet file's, with its scripts')
    scenario_digest: str = ""

    @property
    def is_fleet(self) -> bool:
        """Whether the scenario is a fleet file (its vehicles say their airframes and controllers)."""
        return is_fleet_scenario(self.scenario)

    @property
    def key(self) -> str:
        """The run's values, named, as people read them (one row of the table each)."""
        return " ".join(f"{k}={v}" for k, v in self.axes().items())

    @property
    def settings(self) -> str:
        """A digest of everything the run flies beyond its key: what its scenario says, its
        controller's gains, its duration. `--resume` keeps a row only when both are the same (a
        30 s run kept the 2 s result of an earlier file under the same key)."""
        flown = [
            self.scenario_digest,
            self.airframe,
            self.controller.kind.value,
            self.controller.gains,
            self.wind,
            self.turbulence,
            self.seed,
            self.duration_s,
        ]
        return hashlib.sha256(json.dumps(flown).encode()).hexdigest()[:16]

    def axes(self) -> dict[str, Any]:
        """The swept values of this run, as table columns."""
        return {
            "scenario": Path(self.scenario).name if "/" in self.scenario else self.scenario,
            "airframe": "per vehicle" if self.is_fleet else self.airframe,
            "controller": "per vehicle" if self.is_fleet else self.controller.name,
            "wind": self.wind,
            "turbulence": self.turbulence,
            "seed": self.seed,
        }


@dataclass(frozen=True)
class SweepSpec:
    name: str
    path: Path
    runs: tuple[RunSpec, ...]
    limits: dict[str, float] = field(default_factory=dict)
    #: the axes with more than one value, in sweep order (what the summary and plot group by)
    varied: tuple[str, ...] = ()
    #: simulated time of every run together, s
    sim_s: float = 0.0


def _list_of_str(data: dict[str, Any], key: str, default: list[str], where: str) -> list[str]:
    value = data.get(key, default)
    if isinstance(value, str):
        value = [value]
    if isinstance(value, list) and len(value) > MAX_VALUES:
        raise ConfigError(f"{where}: '{key}' lists {len(value)} values; a sweep takes at most {MAX_VALUES} per axis")
    if not isinstance(value, list) or not value or not all(isinstance(v, (str, int, float)) for v in value):
        raise ConfigError(f"{where}: '{key}' must be a non-empty list of strings, got {_short(value)}")
    out = [str(v) for v in value]
    twice = [v for v, n in collections.Counter(out).items() if n > 1]
    if twice:
        raise ConfigError(f"{where}: '{key}' lists {_short(twice[0])} twice")
    return out


def _short(value: Any) -> str:
    """A value for an error line: its repr, cut to 80 characters."""
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _controllers(data: Any, where: str) -> list[ControllerChoice]:
    if data is None:
        return [ControllerChoice("cascade", ControllerKind.CASCADE)]
    if not isinstance(data, dict) or not data:
        raise ConfigError(f'{where}: [controllers] must be tables like [controllers.cascade] with kind = "cascade"')
    if len(data) > MAX_VALUES:
        raise ConfigError(f"{where}: [controllers] has {len(data)} tables; a sweep takes at most {MAX_VALUES}")
    kinds = [k.value for k in ControllerKind]
    out = []
    for name, table in data.items():
        if not isinstance(table, dict):
            raise ConfigError(f"{where}: controllers.{name} must be a table (kind = ..., gains = {{...}})")
        refuse_unknown_keys(table, ["kind", "gains"], f"{where}: controllers.{name}")
        kind = table.get("kind", name)
        if kind not in kinds:
            raise ConfigError(f"{where}: controllers.{name}: kind must be one of {', '.join(kinds)}, got {kind!r}")
        gains = table.get("gains", {})
        if not isinstance(gains, dict):
            raise ConfigError(f"{where}: controllers.{name}.gains must be a table of numbers")
        for g, v in gains.items():
            problem = gain_problem(gains_type(ControllerKind(kind)), v)
            if problem is not None:
                raise ConfigError(f"{where}: controllers.{name}.gains.{g} = {v!r:.40}: {problem}")
        _check_gains(ControllerKind(kind), gains, f"{where}: controllers.{name}")
        out.append(ControllerChoice(name, ControllerKind(kind), tuple(sorted((k, float(v)) for k, v in gains.items()))))
    return out


def _check_gains(kind: ControllerKind, gains: dict[str, Any], where: str) -> None:
    """Gains the controller does not have are named now, not when a worker builds it."""
    import dataclasses

    known = [f.name for f in dataclasses.fields(gains_type(kind))]
    for g in gains:
        if g not in known:
            near = near_miss(g, known)
            hint = f"did you mean {near!r}?" if near else f"its gains are {', '.join(known)}"
            raise ConfigError(f"{where}: unknown {kind.value} gain {g!r} ({hint})")


def load_sweep(path: Path) -> SweepSpec:
    """Read and check a sweep file; every mistake is a ConfigError naming the file and the key."""
    from quadsim.vehicle.params import SHIPPED_VEHICLES

    where = str(path)
    data = read_toml(path, "sweep file")
    if isinstance(data.get("vehicle"), list) and not KNOWN_KEYS & data.keys():
        raise ConfigError(
            f"{where}: a fleet file, not a sweep file: fly it with 'run --fleet {path.name}', or sweep it from a "
            f'sweep file\'s scenarios = ["{path.name}"]'
        )
    refuse_unknown_keys(
        data, sorted(KNOWN_KEYS), where, top_level=True, otherwise=f"a sweep file has {', '.join(sorted(KNOWN_KEYS))}"
    )
    name = data.get("name", path.stem)
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name.strip()):
        raise ConfigError(
            f"{where}: 'name' must be a plain folder name (letters, digits, space, . _ + -; at most 100; "
            f"no path), got {_short(name)}"
        )
    scenarios, lengths_s, digests = _scenarios(data, path, where)
    if any(is_fleet_scenario(s) for s in scenarios):
        given = [key for key in ("airframes", "controllers") if key in data]
        if given:
            raise ConfigError(
                f"{where}: '{given[0]}' with a fleet file among the scenarios: its vehicles name their own "
                "airframes and controllers (sweep fleets over wind, turbulence and seeds)"
            )
    airframes = _list_of_str(data, "airframes", ["quad"], where)
    for a in airframes:
        if a not in SHIPPED_VEHICLES:
            raise ConfigError(f"{where}: airframes: unknown airframe {a!r}; choose from {', '.join(SHIPPED_VEHICLES)}")
    seeds = data.get("seeds", 1)
    if isinstance(seeds, bool) or not isinstance(seeds, int) or not 1 <= seeds <= 10_000:
        raise ConfigError(f"{where}: 'seeds' must be a whole number from 1 to 10000, got {seeds!r}")
    duration = _duration(data, lengths_s, where)
    winds = _list_of_str(data, "wind", ["0,0"], where)
    turbulences = _list_of_str(data, "turbulence", ["none"], where)
    for w in winds:
        check_wind(w, f"{where}: wind")
    for t in turbulences:
        check_turbulence(t, f"{where}: turbulence")
    axes: dict[str, list[Any]] = {
        "scenario": scenarios,
        "airframe": airframes,
        "controller": _controllers(data.get("controllers"), where),
        "wind": winds,
        "turbulence": turbulences,
    }
    limits = _limits(data, where)
    runs, sim_s = _runs(axes, seeds, duration, lengths_s, where)
    runs = tuple(replace(run, scenario_digest=digests[run.scenario]) for run in runs)
    varied = tuple(k for k, values in axes.items() if len(values) > 1)
    return SweepSpec(name.strip(), path, runs, limits, varied, sim_s)


def _scenarios(data: dict[str, Any], path: Path, where: str) -> tuple[list[str], dict[str, float], dict[str, str]]:
    """The scenarios (built-in names, or script files beside the sweep file), each loaded now so
    that a missing one is found before run 37, their lengths and digests of what they fly."""
    from quadsim.drivers.scripted import load_script

    scenarios = []
    lengths_s: dict[str, float] = {}
    digests: dict[str, str] = {}
    for s in _list_of_str(data, "scenarios", [], where):
        candidate = (path.parent / s).resolve()
        if is_fleet_scenario(s):
            scenarios.append(str(candidate))
            lengths_s[str(candidate)], digests[str(candidate)] = _fleet_length_s(candidate, data, where)
            continue
        ref = str(candidate) if (s.endswith(".qscript") or "/" in s) else s
        try:
            script = load_script(ref)
        except Exception as exc:  # a ConfigError, or a ScriptError (a QuadsimError, not a ConfigError)
            raise ConfigError(f"{where}: scenarios: {exc}") from None
        scenarios.append(ref)
        lengths_s[ref] = script.duration_s
        digests[ref] = _digest(_flown(script))
    return scenarios, lengths_s, digests


def _flown(script: Script) -> str:
    """What a script flies, as text: its z-mode and segments (a comment or a blank line changes
    nothing, so it re-flies nothing)."""
    return repr((script.z_mode, script.segments))


def _digest(*texts: str) -> str:
    return hashlib.sha256("\0".join(texts).encode()).hexdigest()[:16]


def _fleet_length_s(path: Path, data: dict[str, Any], where: str) -> tuple[float, str]:
    """A fleet file as a scenario, checked now: its vehicles fly scripts or sit idle (a sweep has
    no window and no live input); how long it flies (its longest script), and a digest of the
    file, its scripts and its vehicles' own airframe files."""
    from quadsim.sim.fleet_file import load_fleet_file
    from quadsim.vehicle.params import SHIPPED_VEHICLES

    try:
        fleet = load_fleet_file(path)
    except ConfigError as exc:
        raise ConfigError(f"{where}: scenarios: {exc}") from None
    live = next((v for v in fleet.vehicles if v.script is None and v.input != "idle"), None)
    if live is not None:
        raise ConfigError(
            f"{where}: scenarios: {path.name}: vehicle {live.name!r} takes input = {live.input!r}; in a sweep every "
            "vehicle flies a script or is idle"
        )
    if fleet.longest_script_s is None and "duration_s" not in data:
        raise ConfigError(f"{where}: scenarios: {path.name}: no vehicle flies a script: give duration_s")
    scripts = [_flown(v.script) for v in fleet.vehicles if v.script is not None]
    airframes = [_airframe_text(v.urdf) for v in fleet.vehicles if v.airframe not in SHIPPED_VEHICLES]
    return fleet.longest_script_s or 0.0, _digest(path.read_text(encoding="utf-8"), *scripts, *airframes)


def _airframe_text(urdf: Path) -> str:
    """What a vehicle of the user's own flies with: its URDF, and the parameter and gains files
    beside it (NAME.params.toml, NAME.gains.toml), as digests of their bytes (read in pieces:
    however large), so that an edit to any of them flies its runs again on --resume."""
    texts = []
    for file in (urdf, urdf.with_suffix(".params.toml"), urdf.with_suffix(".gains.toml")):
        try:
            digest = hashlib.sha256()
            with file.open("rb") as f:
                for piece in iter(lambda: f.read(1 << 20), b""):
                    digest.update(piece)
            texts.append(f"{file.name} {digest.hexdigest()}")
        except OSError:  # no gains file: the vehicle flies the default gains, which ship with quadsim
            texts.append(f"{file.name} (none)")
    return " ".join(texts)


def _duration(data: dict[str, Any], lengths_s: dict[str, float], where: str) -> float | None:
    """duration_s, or None for each scenario's own length; either way every run must end."""
    duration = data.get("duration_s")
    if duration is not None and (
        isinstance(duration, bool) or not isinstance(duration, (int, float)) or not 0 < duration <= MAX_RUN_S
    ):
        raise ConfigError(
            f"{where}: 'duration_s' must be a number of seconds in (0, {MAX_RUN_S:.0f}], got {_short(duration)}"
        )
    if duration is None:  # every run must end: each scenario's own length bounds it
        for s, length_s in lengths_s.items():
            if not length_s <= MAX_RUN_S:
                raise ConfigError(
                    f"{where}: scenario {Path(s).name} lasts {length_s:.6g} s, more than a run may "
                    f"({MAX_RUN_S:.0f} s): give duration_s to bound it"
                )
    return None if duration is None else float(duration)


def _limits(data: dict[str, Any], where: str) -> dict[str, float]:
    limits = data.get("limits", {})
    if not isinstance(limits, dict):
        raise ConfigError(f"{where}: [limits] must be a table of metric = highest allowed value")
    _check_limit_names(limits, where)
    for k, v in limits.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ConfigError(f"{where}: limits.{k} must be a finite number, got {_short(v)}")
        if v < 0:  # every metric is 0 or more: every run would fail
            raise ConfigError(f"{where}: limits.{k} = {v:g}: a limit is the highest value allowed, 0 or more")
    return {k: float(v) for k, v in limits.items()}


def _check_limit_names(limits: dict[str, Any], where: str) -> None:
    from quadsim.apps.sweep.metrics import METRICS

    for k in limits:
        if k not in METRICS:
            raise ConfigError(f"{where}: limits.{k}: no such metric; metrics are {', '.join(METRICS)}")


def _runs(
    axes: dict[str, list[Any]], seeds: int, duration: float | None, lengths_s: dict[str, float], where: str
) -> tuple[tuple[RunSpec, ...], float]:
    """Every combination of the axes and the seeds, numbered, within the run-count limit, and
    the simulated time they add up to."""
    scenarios = axes["scenario"]
    count = math.prod(len(values) for values in axes.values()) * seeds
    per_scenario_s = [duration if duration is not None else lengths_s[s] for s in scenarios]
    sim_s = sum(per_scenario_s) * (count // len(scenarios))
    if count > MAX_RUNS:
        raise ConfigError(f"{where}: {count} runs is more than {MAX_RUNS}; sweep fewer values at once")
    runs = tuple(
        RunSpec(i, s, a, c, w, t, seed, duration, duration if duration is not None else lengths_s[s])
        for i, (s, a, c, w, t, seed) in enumerate(itertools.product(*axes.values(), range(seeds)))
    )
    return runs, sim_s


TURBULENCE_LEVELS = ("none", *(t.value for t in Turbulence))


def check_wind(text: str, where: str) -> None:
    try:
        wind_from_text(text, None)
    except ConfigError as exc:
        raise ConfigError(f"{where}: {str(exc).replace('--wind', 'a wind')}") from None


def check_turbulence(text: str, where: str) -> None:
    if text not in TURBULENCE_LEVELS:
        raise ConfigError(f"{where}: {text!r} is not one of {', '.join(TURBULENCE_LEVELS)}")
