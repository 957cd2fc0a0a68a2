"""The scripted driver: a timeline of Twist commands from a small text format.

Script format (one statement per line; `#` starts a comment):

    z_mode height            # optional: velocity (default) or height; --z-mode overrides it
    2.5  linear.z=0          # DURATION_S then FIELD=VALUE...: publish this Twist for 2.5 s
    3.0  linear.x=1.0 angular.z=0.5
    1.0                      # no fields: a zero Twist (hover in place)
    silence 2.0              # publish nothing for 2 s (the dead-man timeout then holds)
    6.0  goto x=3 y=-2 z=1.5 yaw_deg=90   # fly to that place for 6 s (quadsim.drivers.goal)

Fields are `linear.x linear.y linear.z angular.x angular.y angular.z` (units of docs/reference/command-semantics.md:
m/s, m/s or m, rad/s); unnamed fields are zero; `angular.x` and `angular.y` are Twist fields the
vehicle ignores, as from every input. A `goto` line gives a goal (world frame, metres; z left out
keeps the altitude flown, yaw_deg left out the heading), flown by the loop's pilot until the next
command line (a `silence` line after it keeps flying it). The z_mode line comes before the first command: a script
flies in one z-mode. Segments follow one another; the script lasts
the sum of their durations. Commands are published at the input rate (20 Hz by default),
each segment from the first poll at or after its start time.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from quadsim.assets import asset_path
from quadsim.core.types import Twist, ZMode
from quadsim.drivers import NEVER
from quadsim.drivers.goal import Goal
from quadsim.errors import ScriptError

#: the largest script file read (a scenario is a few hundred bytes; a day of 0.05 s segments fits)
MAX_SCRIPT_BYTES = 4 * 1024 * 1024
#: the longest a script may last: what a run may fly (run --duration's limit, 7 days)
MAX_SCRIPT_S = 7 * 24 * 3600.0

_FIELDS = ("linear.x", "linear.y", "linear.z", "angular.x", "angular.y", "angular.z")
_GOAL_FIELDS = ("x", "y", "z", "yaw_deg")


@dataclass(frozen=True)
class Segment:
    duration_s: float
    twist: Twist | None  # None: silence (or a goal)
    goal: Goal | None = None  # a goto line's


@dataclass(frozen=True)
class Script:
    name: str
    segments: tuple[Segment, ...]
    z_mode: ZMode | None  # what the script asks for; None: the run's default
    source: str  # the script's text, kept so a recording can fly it again

    @property
    def duration_s(self) -> float:
        return sum(s.duration_s for s in self.segments)


def parse_script(text: str, name: str = "<script>") -> Script:
    """Parse the script format; raises ScriptError naming the line at fault."""
    segments: list[Segment] = []
    z_mode: ZMode | None = None
    text = text.removeprefix("\ufeff")  # a byte-order mark is not a command
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        where = f"{name}, line {lineno}"
        words = line.split()
        head = words[0].lower()
        if head == "z_mode":
            if len(words) != 2 or words[1].lower() not in ("velocity", "height"):
                raise ScriptError(f"{where}: expected 'z_mode velocity' or 'z_mode height', got {line!r}")
            if z_mode is not None or segments:  # it would have applied to the whole script
                raise ScriptError(
                    f"{where}: a script flies in one z-mode, set by one z_mode line before its first command "
                    f"({'a z_mode line came before' if z_mode is not None else 'commands came before'})"
                )
            z_mode = ZMode(words[1].lower())
            continue
        if len(words) > 1 and words[1].lower() == "goto":
            segments.append(Segment(_duration(words[0], where), None, _goal(words[2:], where, line)))
            continue
        silence = head == "silence"
        if silence:
            words = words[1:]
            if len(words) != 1:
                raise ScriptError(f"{where}: expected 'silence DURATION_S', got {line!r}")
        duration = _duration(words[0], where)
        values = {**dict.fromkeys(_FIELDS, 0.0), **_assignments(words[1:], _FIELDS, where)}
        segments.append(
            Segment(duration, None if silence else Twist(**{f.replace(".", "_"): v for f, v in values.items()}))
        )
    if not segments:
        raise ScriptError(f"{name}: the script has no command lines")
    total = sum(seg.duration_s for seg in segments)
    if total > MAX_SCRIPT_S:
        raise ScriptError(
            f"{name}: its lines last {total:.6g} s, more than a run may fly ({MAX_SCRIPT_S / 86400:.0f} days, "
            "as --duration)"
        )
    return Script(name, tuple(segments), z_mode, text)


def _duration(text: str, where: str) -> float:
    duration = _number(text, where, "duration")
    if duration <= 0:
        raise ScriptError(f"{where}: duration must be > 0 s, got {text}")
    return duration


def _goal(words: list[str], where: str, line: str) -> Goal:
    """A goto line's goal: x=.. y=.. (needed), z=.. yaw_deg=.. (optional)."""
    values = _assignments(words, _GOAL_FIELDS, where)
    if "x" not in values or "y" not in values:
        raise ScriptError(f"{where}: a goto line needs x= and y= (z= and yaw_deg= are optional), got {line!r}")
    yaw = values.get("yaw_deg")
    try:
        return Goal(values["x"], values["y"], values.get("z"), None if yaw is None else math.radians(yaw)).checked()
    except ValueError as exc:
        raise ScriptError(f"{where}: {exc}") from None


def _assignments(words: list[str], fields: tuple[str, ...], where: str) -> dict[str, float]:
    """A line's FIELD=VALUE words, each FIELD one of `fields` and given once, as numbers."""
    values: dict[str, float] = {}
    for word in words:
        key, sep, value = word.partition("=")
        if not sep or key not in fields:
            raise ScriptError(f"{where}: expected FIELD=VALUE with FIELD one of {', '.join(fields)}, got {word!r}")
        if key in values:
            raise ScriptError(f"{where}: {key} is given twice")
        values[key] = _number(value, where, key)
    return values


def _number(text: str, where: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ScriptError(f"{where}: {what} must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise ScriptError(f"{where}: {what} must be finite, got {text!r}")
    return value


def builtin_scenarios() -> dict[str, str]:
    """Names of the shipped scenarios and their first comment line."""
    return {
        entry.name.removesuffix(".qscript"): entry.read_text().splitlines()[0].lstrip("# ").strip()
        for entry in sorted(asset_path("scenarios").iterdir(), key=lambda e: e.name)
        if entry.name.endswith(".qscript")
    }


def load_script(name_or_path: str) -> Script:
    """A built-in scenario by name, or a script file by path."""
    if not name_or_path.strip():
        raise ScriptError("no script named: give a built-in scenario's name or a script file path")
    path = Path(name_or_path)
    if path.suffix or path.exists() or "/" in name_or_path:
        if not path.exists():
            raise ScriptError(f"script file not found: {name_or_path}")
        if not path.is_file():
            raise ScriptError(f"not a script file (a directory or a device): {name_or_path}")
        try:
            with path.open("rb") as fh:
                raw = fh.read(MAX_SCRIPT_BYTES + 1)
        except OSError as exc:
            raise ScriptError(f"cannot read script {name_or_path}: {exc.strerror or exc}") from None
        if len(raw) > MAX_SCRIPT_BYTES:
            raise ScriptError(f"script {name_or_path} is larger than {MAX_SCRIPT_BYTES // (1024 * 1024)} MB")
        try:
            text = raw.decode("utf-8-sig")  # a BOM from a Windows editor is not a command
        except UnicodeDecodeError:
            raise ScriptError(f"script {name_or_path} is not a UTF-8 text file") from None
        return parse_script(text, str(path))
    scenarios = builtin_scenarios()
    if name_or_path not in scenarios:
        raise ScriptError(
            f"unknown scenario {name_or_path!r}; built-in scenarios: {', '.join(scenarios)} (or give a script file path)"
        )
    text = asset_path("scenarios", name_or_path + ".qscript").read_text()
    return parse_script(text, name_or_path)


class ScriptedDriver:
    """Plays a Script: at each poll, the Twist of the segment the time falls in."""

    name = "scripted"
    next_poll_step = NEVER  # commands follow the input rate only

    def __init__(self, script: Script) -> None:
        self.script = script
        self._ends = tuple(itertools.accumulate(seg.duration_s for seg in script.segments))
        self.rewind()

    def rewind(self) -> None:
        """Play the script from its start again (the simulator's reset: time starts at 0 again)."""
        self._index = 0
        self._finished = False
        self._goal_given = -1  # the index of the last goto segment whose goal was handed on

    @property
    def preferred_z_mode(self) -> ZMode | None:
        """The z-mode the script is written for (its `z_mode` line); the Simulator uses it
        unless the run's configuration says otherwise."""
        return self.script.z_mode

    def poll(self, step: int, time_s: float) -> Twist | None:
        ends = self._ends
        # a small tolerance keeps a boundary at 2.0 s from landing on 1.99999 by float sums
        while self._index < len(ends) and time_s >= ends[self._index] - 1e-9:
            self._index += 1
        if self._index >= len(ends):
            self._finished = True
            return None
        return self.script.segments[self._index].twist

    def take_goal(self) -> Goal | None:
        """The goal of the goto segment just entered (once), or None."""
        if self._index < len(self._ends) and self._goal_given != self._index:
            goal = self.script.segments[self._index].goal
            if goal is not None:
                self._goal_given = self._index
                return goal
        return None

    @property
    def finished(self) -> bool:
        return self._finished

    def describe(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "script": self.script.name,
            "source": self.script.source,
            "z_mode": self.script.z_mode.value if self.script.z_mode else None,
        }
