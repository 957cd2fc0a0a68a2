"""`replay --plot FILE.png`: a recorded flight drawn with matplotlib (Agg, no display needed).

Left, the track seen from above with the world's landmarks; right, what was commanded against
what was flown, over time: forward and sideways speed in the heading frame, climb rate or
altitude (by the z-mode in effect, shaded where height mode held), and yaw rate.
"""

from __future__ import annotations

import itertools
import math
import tempfile
from pathlib import Path
from typing import Any

from quadsim.core.files import write_whole
from quadsim.core.invocation import install_extra
from quadsim.core.types import HEIGHT_MODE_BASE_M, VehicleState, ZMode
from quadsim.errors import QuadsimError
from quadsim.physics.world_spec import WorldSpec, load_world
from quadsim.recording.contract import POSE, Names
from quadsim.recording.flight import NS, RecordedFlight

COMMAND_COLOUR = "#1f77b4"
FLOWN_COLOUR = "#d62728"
OTHERS_COLOUR = "#8c8c8c"


def _matplotlib() -> Any:
    try:
        import matplotlib
    except ImportError:
        raise QuadsimError(f"plots need matplotlib: {install_extra('plot')}") from None
    matplotlib.use("Agg", force=True)  # files only: no display, no GUI toolkit
    import matplotlib.pyplot as plt

    return plt


def require_matplotlib() -> None:
    """Raise the one-line error now, before a command does work whose end is the plot."""
    _matplotlib()


def _heading_velocity(s: VehicleState) -> tuple[float, float]:
    yaw = s.yaw_rad()
    vx, vy, _ = s.linear_velocity_mps
    return math.cos(yaw) * vx + math.sin(yaw) * vy, -math.sin(yaw) * vx + math.cos(yaw) * vy


def _steps(f: RecordedFlight, value, mode: ZMode | None = None) -> tuple[list[float], list[float]]:
    """Commands as a step line, each held until the next or until the dead-man timeout fired (the
    line breaks there: no command, the vehicle holds); NaN breaks it too where the z-mode in effect
    is not `mode`."""
    timeout_s = f.description.config.command_timeout_s if f.description else None
    timeout_ns = math.inf if timeout_s is None else timeout_s * NS
    ts: list[float] = []
    vs: list[float] = []
    for (ns, twist), nxt in zip(f.commands, [*f.commands[1:], (f.end_ns, None)]):
        v = value(twist) if mode is None or f.z_mode_at(ns) is mode else math.nan
        end = min(nxt[0], ns + timeout_ns)
        ts += [ns / NS, end / NS]
        vs += [v, v]
        if end < nxt[0]:  # silence: nothing commanded until the next
            ts.append(end / NS)
            vs.append(math.nan)
    return ts, vs


def _height_spans(f: RecordedFlight) -> list[tuple[float, float]]:
    """Time spans (s) in which the height z-mode was in effect."""
    marks = [0] + [step * NS // f.physics_hz for step, kind, _ in f.events if kind == "z_mode"] + [f.end_ns]
    spans = []
    for a, b in itertools.pairwise(marks):
        if b > a and f.z_mode_at(a) is ZMode.HEIGHT:
            spans.append((a / NS, b / NS))
    return spans


def recorded_world(f: RecordedFlight) -> WorldSpec | None:
    """The world the recording was flown in, from its attachment (None: it has none, or one that
    does not read: the track is drawn alone). The replay window's map draws it too."""
    d = f.description
    name = d.config.world.name if d is not None and d.config.world is not None else "default.toml"
    data = f.attachments.get(name)
    if not data:
        return None
    try:
        with tempfile.TemporaryDirectory(prefix="quadsim-world-") as tmp:
            path = Path(tmp) / "world.toml"
            path.write_bytes(data)
            return load_world(path, texture_required=False)
    except Exception:  # a world that does not read, or a temporary folder that cannot take it
        return None


def _landmarks(f: RecordedFlight) -> list[tuple[str, float, float, tuple[float, float, float]]]:
    """(name, x, y, colour) of the landmarks of the world the recording was flown in."""
    world = recorded_world(f)
    landmarks = world.landmarks if world is not None else ()
    return [(lm.name, lm.position_m[0], lm.position_m[1], lm.color_rgba[:3]) for lm in landmarks]


def _draw_track(
    track: Any,
    states: list[VehicleState],
    landmarks: list[tuple[str, float, float, Any]],
    others: dict[str, list[VehicleState]],
    name: str,
) -> None:
    """The flown track seen from above, with the world's landmarks, the start and the end; in a
    fleet, the other vehicles' tracks in grey, each named at its end."""
    xs, ys = [s.position_m[0] for s in states], [s.position_m[1] for s in states]
    for landmark, x, y, colour in landmarks:
        track.plot(x, y, "s", color=colour, markersize=9, alpha=0.8)
        track.annotate(landmark.replace("_", " "), (x, y), textcoords="offset points", xytext=(6, 6), fontsize=8)
    for i, (other, flown) in enumerate(others.items()):
        oxs, oys = [s.position_m[0] for s in flown], [s.position_m[1] for s in flown]
        track.plot(oxs, oys, color=OTHERS_COLOUR, linewidth=1.2, label="the fleet's other vehicles" if i == 0 else None)
        track.plot(oxs[-1], oys[-1], "X", color=OTHERS_COLOUR)
        track.annotate(other, (oxs[-1], oys[-1]), textcoords="offset points", xytext=(6, -10), fontsize=8)
    if others:
        track.annotate(name, (xs[-1], ys[-1]), textcoords="offset points", xytext=(6, -10), fontsize=8)
    track.plot(xs, ys, color=FLOWN_COLOUR, linewidth=1.6, label=f"flown track{f' of {name}' if others else ''}")
    # above the landmarks' squares (a start on the landing pad was hidden under it)
    track.plot(xs[0], ys[0], "o", color="#2ca02c", label="start", zorder=5)
    track.plot(xs[-1], ys[-1], "X", color="black", label="end", zorder=5)
    track.set_xlabel("x, world (m)")
    track.set_ylabel("y, world (m)")
    track.set_title("track seen from above")
    track.set_aspect("equal", adjustable="datalim")
    track.grid(True, alpha=0.3)
    track.legend(loc="best", fontsize=8)


#: the least height of a panel's y axis, in its units: a field that stays at 0 (or within rounding
#: of it) is drawn flat, not autoscaled until 1e-16 looks like a wild oscillation
MIN_SPAN = 0.2


def _at_least(ax: Any, span: float) -> None:
    low, high = ax.get_ylim()
    if high - low < span:
        middle = (low + high) / 2.0
        ax.set_ylim(middle - span / 2.0, middle + span / 2.0)


def _draw_panels(
    fig: Any,
    grid: Any,
    panels: list[tuple[str, str, tuple[list[float], list[float]], list[float]]],
    t: list[float],
    spans: list[tuple[float, float]],
    end_s: float,
) -> None:
    """One panel a command field, commanded against flown, on a shared time axis, with the
    stretches flown in height z-mode shaded."""
    first = None
    for row, (title, unit, command, flown) in enumerate(panels):
        ax = fig.add_subplot(grid[row, 1], sharex=first)
        first = first or ax
        for a, b in spans:
            ax.axvspan(
                a, b, color="#f0e6c8", alpha=0.6, linewidth=0, label="height z-mode" if (a, b) == spans[0] else None
            )
        ax.plot(*command, color=COMMAND_COLOUR, linewidth=1.4, linestyle="--", label="commanded")
        ax.plot(t, flown, color=FLOWN_COLOUR, linewidth=1.2, label="flown")
        ax.set_ylabel(f"{title}\n({unit})", fontsize=9)
        ax.grid(True, alpha=0.3)
        _at_least(ax, MIN_SPAN)
        if row == 0:
            ax.legend(loc="upper right", fontsize=8, ncols=3)
        if row < len(panels) - 1:
            ax.tick_params(labelbottom=False)
    assert first is not None
    first.set_xlim(0.0, end_s)
    ax.set_xlabel("simulation time (s)")


def export_plot(f: RecordedFlight, path: Path, others: dict[str, list[VehicleState]] | None = None) -> Path:
    """Write the plot to `path` (.png, .jpg, .pdf or .svg) and return it; `others`: in a fleet's
    recording, the other vehicles' states by name, drawn on the track."""
    if not f.states:
        raise QuadsimError(f"{f.path}: has no {Names(f.vehicle).topic(POSE).name} states to plot")
    plt = _matplotlib()
    landmarks = _landmarks(f)
    states = f.states
    t = [s.step / f.physics_hz for s in states]
    heading_v = [_heading_velocity(s) for s in states]
    spans = _height_spans(f)
    any_height = bool(spans)

    fig = plt.figure(figsize=(14, 8), layout="constrained")
    grid = fig.add_gridspec(4, 2, width_ratios=(1.0, 1.35))
    fig.suptitle(
        f"{f.path.name}: {f.duration_s:.1f} s"
        + (f", vehicle {f.vehicle} of a fleet of {len(others or {}) + 1}" if f.vehicle else "")
        + (f", {f.description.controller.name} controller" if f.description else "")
    )

    _draw_track(
        fig.add_subplot(grid[:, 0]), states, landmarks, {k: v for k, v in (others or {}).items() if v}, f.vehicle
    )

    if any_height:
        z_title, z_unit = "altitude", "m"
        z_command = _steps(f, lambda tw: tw.linear_z + HEIGHT_MODE_BASE_M, ZMode.HEIGHT)
        z_flown = [s.position_m[2] for s in states]
    else:
        z_title, z_unit = "climb rate", "m/s"
        z_command = _steps(f, lambda tw: tw.linear_z)
        z_flown = [s.linear_velocity_mps[2] for s in states]
    panels: list[tuple[str, str, tuple[list[float], list[float]], list[float]]] = [
        ("forward speed", "m/s", _steps(f, lambda tw: tw.linear_x), [v[0] for v in heading_v]),
        ("sideways speed (left +)", "m/s", _steps(f, lambda tw: tw.linear_y), [v[1] for v in heading_v]),
        (z_title, z_unit, z_command, z_flown),
        (
            "yaw rate (ccw +)",
            "rad/s",
            _steps(f, lambda tw: tw.angular_z),
            [s.angular_velocity_body_rps[2] for s in states],
        ),
    ]
    _draw_panels(fig, grid, panels, t, spans, max(f.duration_s, t[-1]))
    exists = f"{path} already exists; choose another --plot (nothing is overwritten)"
    try:
        write_whole(path, lambda fh: fig.savefig(fh, dpi=100, format=path.suffix[1:].lower()), exists)
    except OSError as exc:
        raise QuadsimError(f"cannot write the plot to {path}: {exc.strerror or exc}; nothing was written") from None
    finally:
        plt.close(fig)
    return path
