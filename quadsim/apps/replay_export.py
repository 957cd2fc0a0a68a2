"""Headless playback: a recording's summary and its camera streams as videos.

Videos are VP9 in an MP4 container: OpenCV's bundled FFmpeg has no H.264 encoder (only a
hardware one that is rarely there), and VP9 is what browsers play besides H.264. The plot is
in flight_plot."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

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


def export_mp4(f: RecordedFlight, folder: Path, progress: Callable[[float], None] | None = None) -> list[Path]:
    """One MP4 (VP9) per camera stream, at the stream's frame rate. `progress` gets the share done."""
    if not f.frames:
        raise QuadsimError(f"{f.path}: has no camera images to export")
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    total, done = sum(len(frames) for frames in f.frames.values()), 0
    for cam, frames in sorted(f.frames.items()):
        first = cv2.imdecode(np.frombuffer(frames[0][1], np.uint8), cv2.IMREAD_COLOR)
        if first is None:
            raise QuadsimError(f"{f.path}: {cam} camera images are not decodable JPEG")
        span = (frames[-1][0] - frames[0][0]) / NS
        fps = (len(frames) - 1) / span if span > 0 else 30.0
        path = folder / f"{f.path.stem}_{cam}.mp4"
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"vp09"), fps, (first.shape[1], first.shape[0]))
        if not writer.isOpened():
            raise QuadsimError(f"OpenCV cannot write MP4 files here ({path})")
        for _, jpeg in frames:
            image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
            if image is not None and image.shape == first.shape:  # skip what cannot be shown
                writer.write(image)
            done += 1
            if progress is not None:
                progress(done / total)
        writer.release()
        written.append(path)
    return written
