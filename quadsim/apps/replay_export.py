"""Headless playback: a recording's summary, its camera streams as MP4, and a plot (PNG) of the
track and of the commands against the state."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from quadsim.core.types import HEIGHT_MODE_BASE_M, VehicleState
from quadsim.errors import QuadsimError
from quadsim.recording.flight import NS, RecordedFlight


def summary_lines(f: RecordedFlight) -> list[str]:
    out = [f"recording   {f.path}", f"duration    {f.duration_s:.2f} s"]
    if f.states:
        dist = sum(math.dist(a.position_m, b.position_m) for a, b in zip(f.states, f.states[1:]))
        top = max(math.hypot(*s.linear_velocity_mps[:2]) for s in f.states)
        last = f.states[-1]
        out += [
            f"flown       {dist:.2f} m, max altitude {max(s.position_m[2] for s in f.states):.2f} m, "
            f"top speed {top:.2f} m/s",
            "final pose  x={:+.2f} y={:+.2f} z={:+.2f} m, yaw {:+.1f} deg".format(
                *last.position_m, math.degrees(last.yaw_rad())
            ),
        ]
    else:
        out.append("states      none (no /quad/pose in this file)")
    out.append(f"commands    {len(f.commands)} on /quad_cmd_twist")
    for cam, frames in sorted(f.frames.items()):
        out.append(f"camera      {cam}: {len(frames)} frames")
    if f.description is not None:
        d = f.description
        out.append(f"flown with  {d.controller.kind.value} controller, z-mode {d.z_mode.value}, {d.driver_name} input")
    elif f.description_error:
        out.append(f"flown with  (run parameters unreadable: {f.description_error})")
    else:
        out.append("flown with  (no quadsim metadata: recorded by another program)")
    return out


def export_mp4(f: RecordedFlight, folder: Path) -> list[Path]:
    """One MP4 per camera stream, at the stream's frame rate."""
    if not f.frames:
        raise QuadsimError(f"{f.path}: has no camera images to export")
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for cam, frames in sorted(f.frames.items()):
        first = cv2.imdecode(np.frombuffer(frames[0][1], np.uint8), cv2.IMREAD_COLOR)
        if first is None:
            raise QuadsimError(f"{f.path}: {cam} camera images are not decodable JPEG")
        span = (frames[-1][0] - frames[0][0]) / NS
        fps = (len(frames) - 1) / span if span > 0 else 30.0
        path = folder / f"{f.path.stem}_{cam}.mp4"
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"mp4v"), fps, (first.shape[1], first.shape[0]))
        if not writer.isOpened():
            raise QuadsimError(f"OpenCV cannot write MP4 files here ({path})")
        for _, jpeg in frames:
            image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
            if image is not None:
                writer.write(image)
        writer.release()
        written.append(path)
    return written


# --- the plot -------------------------------------------------------------------------------

WHITE, GREY, BLACK = (255, 255, 255), (200, 200, 200), (40, 40, 40)
COMMAND, ACTUAL = (40, 120, 230), (30, 30, 200)  # BGR: orange-ish blue for command, red for state


def _heading_velocity(s: VehicleState) -> tuple[float, float]:
    yaw = s.yaw_rad()
    vx, vy, _ = s.linear_velocity_mps
    return math.cos(yaw) * vx + math.sin(yaw) * vy, -math.sin(yaw) * vx + math.cos(yaw) * vy


def _panel(
    img: np.ndarray,
    box: tuple[int, int, int, int],
    title: str,
    t_end: float,
    series: list[tuple[list, tuple[int, int, int], str]],
    unit: str,
) -> None:
    x, y, w, h = box
    cv2.rectangle(img, (x, y), (x + w, y + h), GREY, 1)
    values = [p[1] for pts, _, _ in series for p in pts if p is not None] or [0.0]
    lo, hi = min(values), max(values)
    if hi - lo < 0.5:  # a minimum span, so that millimetre noise does not fill the panel
        mid = (hi + lo) / 2
        lo, hi = mid - 0.25, mid + 0.25
    pad = 0.1 * (hi - lo)
    lo, hi = lo - pad, hi + pad

    def px(t: float, v: float) -> tuple[int, int]:
        return int(x + t / max(t_end, 1e-9) * w), int(y + h - (v - lo) / (hi - lo) * h)

    if lo < 0 < hi:
        cv2.line(img, px(0, 0), px(t_end, 0), GREY, 1)
    for pts, color, _ in series:
        runs: list[list[tuple[int, int]]] = [[]]
        for p in pts:  # None breaks the line
            if p is None:
                runs.append([])
            else:
                runs[-1].append(px(*p))
        for run in runs:
            if len(run) > 1:
                cv2.polylines(img, [np.array(run, np.int32)], False, color, 2, cv2.LINE_AA)
    cv2.putText(img, f"{title} ({unit})", (x + 6, y + 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, BLACK, 1, cv2.LINE_AA)
    cv2.putText(img, f"{hi:.2f}", (x - 52, y + 12), cv2.FONT_HERSHEY_SIMPLEX, 0.4, BLACK, 1, cv2.LINE_AA)
    cv2.putText(img, f"{lo:.2f}", (x - 52, y + h), cv2.FONT_HERSHEY_SIMPLEX, 0.4, BLACK, 1, cv2.LINE_AA)
    for i, (_, color, label) in enumerate(series):
        cv2.putText(img, label, (x + w - 170 + 85 * i, y - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.45, color, 1, cv2.LINE_AA)


def export_plot(f: RecordedFlight, path: Path) -> Path:
    """Track seen from above (left) and commands against the state over time (right)."""
    if not f.states:
        raise QuadsimError(f"{f.path}: has no /quad/pose states to plot")
    img = np.full((900, 1400, 3), 255, np.uint8)
    # track
    xs = [s.position_m[0] for s in f.states]
    ys = [s.position_m[1] for s in f.states]
    span = max(max(xs) - min(xs), max(ys) - min(ys), 2.0) * 1.15
    cx, cy = (max(xs) + min(xs)) / 2, (max(ys) + min(ys)) / 2
    box = (40, 60, 520, 520)
    k = box[2] / span

    def tp(x: float, y: float) -> tuple[int, int]:  # world x up, world y to the left
        return int(box[0] + box[2] / 2 - (y - cy) * k), int(box[1] + box[3] / 2 - (x - cx) * k)

    step = 1.0 if span < 20 else 5.0
    area = img[box[1] : box[1] + box[3], box[0] : box[0] + box[2]]  # a view: the grid stays inside the box
    for g in np.arange(math.floor((cx - span) / step) * step, cx + span, step):
        a, b = tp(g, cy - span), tp(g, cy + span)
        cv2.line(area, (a[0] - box[0], a[1] - box[1]), (b[0] - box[0], b[1] - box[1]), (235, 235, 235), 1)
    for g in np.arange(math.floor((cy - span) / step) * step, cy + span, step):
        a, b = tp(cx - span, g), tp(cx + span, g)
        cv2.line(area, (a[0] - box[0], a[1] - box[1]), (b[0] - box[0], b[1] - box[1]), (235, 235, 235), 1)
    cv2.rectangle(img, (box[0], box[1]), (box[0] + box[2], box[1] + box[3]), GREY, 1)
    pts = np.array([tp(x, y) for x, y in zip(xs, ys)], np.int32)
    cv2.polylines(img, [pts], False, ACTUAL, 2, cv2.LINE_AA)
    cv2.circle(img, tuple(pts[0]), 6, (60, 160, 60), -1)
    cv2.circle(img, tuple(pts[-1]), 6, (30, 30, 200), -1)
    cv2.putText(
        img,
        f"track from above, grid {step:g} m (start green, end red; up = world +x)",
        (box[0], box[1] - 12),
        cv2.FONT_HERSHEY_SIMPLEX,
        0.5,
        BLACK,
        1,
        cv2.LINE_AA,
    )
    cv2.putText(img, f.path.name, (box[0], box[1] + box[3] + 30), cv2.FONT_HERSHEY_SIMPLEX, 0.5, BLACK, 1, cv2.LINE_AA)
    # time series: commanded vs flown
    t_end = f.duration_s
    initial = f.description.z_mode.value if f.description else "velocity"
    switches = [(step / f.physics_hz, value) for step, kind, value in f.events if kind == "z_mode"]

    def z_mode_at(t: float) -> str:
        mode = initial
        for when, value in switches:
            if when <= t:
                mode = value
        return mode

    any_height = initial == "height" or any(v == "height" for _, v in switches)

    def cmd(fn, only_mode: str | None = None) -> list[tuple[float, float] | None]:
        """Commands as steps (each held until the next); None breaks the line where the
        z-mode gives linear.z another meaning."""
        out: list[tuple[float, float] | None] = []
        last = None
        for ns, tw in f.commands:
            t = ns / NS
            if only_mode is not None and z_mode_at(t) != only_mode:
                if last is not None:
                    out += [(t, last), None]
                last = None
                continue
            if last is not None:
                out.append((t, last))
            last = fn(tw)
            out.append((t, last))
        if last is not None:
            out.append((t_end, last))
        return out

    state_t = [s.step / f.physics_hz for s in f.states]
    hv = [_heading_velocity(s) for s in f.states]
    if any_height:
        z_panel = (
            "altitude" + (" (height z-mode parts)" if switches else ""),
            "m",
            cmd(lambda t: t.linear_z + HEIGHT_MODE_BASE_M, "height"),
            list(zip(state_t, (s.position_m[2] for s in f.states))),
        )
    else:
        z_panel = (
            "climb rate",
            "m/s",
            cmd(lambda t: t.linear_z),
            list(zip(state_t, (s.linear_velocity_mps[2] for s in f.states))),
        )
    panels = [
        ("forward speed", "m/s", cmd(lambda t: t.linear_x), list(zip(state_t, (v[0] for v in hv)))),
        ("sideways speed (left +)", "m/s", cmd(lambda t: t.linear_y), list(zip(state_t, (v[1] for v in hv)))),
        z_panel,
        (
            "yaw rate (ccw +)",
            "rad/s",
            cmd(lambda t: t.angular_z),
            list(zip(state_t, (s.angular_velocity_body_rps[2] for s in f.states))),
        ),
    ]
    x0, w, h, gap = 660, 700, 170, 40
    for i, (title, unit, commanded, flown) in enumerate(panels):
        series: list[tuple[list, tuple[int, int, int], str]] = [
            (commanded, COMMAND, "command"),
            (flown, ACTUAL, "flown"),
        ]
        _panel(img, (x0, 60 + i * (h + gap), w, h), title, t_end, series, unit)
    cv2.putText(
        img,
        f"time (s), 0 .. {t_end:.1f}",
        (x0 + w // 2 - 60, 60 + 4 * (h + gap) - 15),
        cv2.FONT_HERSHEY_SIMPLEX,
        0.5,
        BLACK,
        1,
        cv2.LINE_AA,
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(path), img):
        raise QuadsimError(f"cannot write {path}")
    return path
