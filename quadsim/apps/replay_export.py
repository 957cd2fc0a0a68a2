"""Headless playback: a recording's summary and its camera streams as videos.

Videos are VP9 in an MP4 container: OpenCV's bundled FFmpeg has no H.264 encoder (only a
hardware one that is rarely there), and VP9 is what browsers play besides H.264. The plot is
in flight_plot."""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from quadsim.errors import QuadsimError
from quadsim.recording.contract import POSE, TWIST, Names
from quadsim.recording.flight import NS, RecordedFlight


def summary_lines(f: RecordedFlight) -> list[str]:
    start_s = f.start_ns / NS  # later than 0: recorded from part-way through a flight (F5)
    span = f" ({start_s:.2f} .. {f.duration_s:.2f} s)" if f.start_ns else ""
    out = [f"recording   {f.path}", f"duration    {f.duration_s - start_s:.2f} s{span}"]
    if f.fleet is not None:
        names = [name for name, _ in f.fleet.fleet]
        out.append(f"fleet       {len(names)} vehicles ({', '.join(names)}); below: {f.vehicle}")
    wire = Names(f.vehicle)
    if f.states:
        dist = sum(math.dist(a.position_m, b.position_m) for a, b in zip(f.states, f.states[1:]))
        top = max(math.hypot(*s.linear_velocity_mps[:2]) for s in f.states)
        last = f.states[-1]
        out += [
            f"flown       {dist:.2f} m, max altitude {max(s.position_m[2] for s in f.states):.2f} m, "
            f"top horizontal speed {top:.2f} m/s",
            "final pose  x={:+.2f} y={:+.2f} z={:+.2f} m, yaw {:+.1f} deg".format(
                *last.position_m, math.degrees(last.yaw_rad())
            ),
        ]
    else:
        out.append(f"states      none (no {wire.topic(POSE).name} in this file)")
    out.append(f"commands    {len(f.commands)} on {wire.topic(TWIST).name}")
    for cam, frames in sorted(f.frames.items()):
        out.append(f"camera      {cam}: {len(frames)} frames")
    if f.description is not None:
        d = f.description
        out.append(f"flown with  {d.controller.name} controller, z-mode {d.z_mode.value}, {d.driver_name} input")
    elif f.description_error:
        out.append(f"flown with  (run parameters unreadable: {f.description_error})")
    else:
        out.append("flown with  (no quadsim metadata: recorded by another program)")
    return out


@dataclass(frozen=True)
class Video:
    path: Path
    frames: int  # encoded (or skipped as undecodable) before the end or a stop
    of: int  # in the stream

    def line(self) -> str:
        short = "" if self.frames == self.of else f", the first {self.frames} of {self.of} frames: stopped"
        return f"video       {self.path} (VP9{short})"


def mp4_target(where: Path, recording: Path) -> tuple[Path, str]:
    """Where `--mp4 WHERE` puts a recording's videos: the folder and the name before `_CAMERA.mp4`
    (WHERE a folder: RECORDING_front.mp4 in it; WHERE NAME.mp4: NAME_front.mp4 beside it)."""
    if where.suffix.lower() == ".mp4":
        return where.parent, where.stem
    if where.suffix and not where.is_dir():  # vid.avi: not a folder to make, nor an MP4 name
        raise QuadsimError(f"--mp4 {where}: give a folder or NAME.mp4 (the videos are MP4, VP9)")
    return where, recording.stem


def mp4_paths(where: Path, f: RecordedFlight) -> dict[str, Path]:
    """The video each camera stream of `f` goes to with `--mp4 WHERE`, refused (before anything is
    made) when the flight has no camera images or a video of that name is already there."""
    if not f.frames:
        whose = f"vehicle {f.vehicle}" if f.vehicle else "it"
        raise QuadsimError(f"{f.path}: {whose} recorded no camera images: there is no video to export")
    folder, stem = mp4_target(where, f.path)
    paths = {cam: folder / f"{stem}_{cam}.mp4" for cam in sorted(f.frames)}
    for path in paths.values():
        if path.exists():
            raise QuadsimError(f"{path} already exists; choose another --mp4 (nothing is overwritten)")
    return paths


def export_mp4(
    f: RecordedFlight,
    where: Path,
    progress: Callable[[int, int], None] | None = None,
    stop: Callable[[], bool] = lambda: False,
) -> list[Video]:
    """One MP4 (VP9) per camera stream, at the stream's frame rate, the streams encoded side by
    side (libvpx holds one core per stream, and OpenCV lets go of the GIL while it encodes).
    `progress(frames done, frames in all)` is called from the encoding threads, one at a time;
    once `stop()` is true every stream ends at its next frame, as a shorter but whole video.
    `where`: a folder (RECORDING_front.mp4 in it), or NAME.mp4 (NAME_front.mp4 beside it)."""
    paths = mp4_paths(where, f)
    streams = []
    for cam, path in paths.items():
        frames = f.frames[cam]
        first = cv2.imdecode(np.frombuffer(frames[0][1], np.uint8), cv2.IMREAD_COLOR)
        if first is None:
            raise QuadsimError(f"{f.path}: {cam} camera images are not decodable JPEG")
        streams.append((path, frames, first.shape))
    next(iter(paths.values())).parent.mkdir(parents=True, exist_ok=True)
    total, done, lock, ended = sum(len(frames) for _, frames, _ in streams), 0, threading.Lock(), threading.Event()

    def next_frame() -> bool:
        """Counts a frame done; False once the encoding is to stop."""
        nonlocal done
        with lock:
            done += 1
            if progress is not None:
                progress(done, total)
        return not (ended.is_set() or stop())

    with ThreadPoolExecutor(max_workers=min(len(streams), os.cpu_count() or 1)) as pool:
        encoding = [pool.submit(_encode, path, frames, shape, next_frame) for path, frames, shape in streams]
        try:
            return [Video(path, future.result(), len(frames)) for (path, frames, _), future in zip(streams, encoding)]
        finally:  # a second Ctrl-C or an error: the other streams end at their next frame
            ended.set()


def _encode(path: Path, frames: list[tuple[int, bytes]], shape: tuple[int, ...], next_frame: Callable[[], bool]) -> int:
    """Encodes `frames` into `path` until `next_frame()` says stop; how many were done."""
    span = (frames[-1][0] - frames[0][0]) / NS
    fps = (len(frames) - 1) / span if span > 0 else 30.0
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"vp09"), fps, (shape[1], shape[0]))
    if not writer.isOpened():
        raise QuadsimError(f"OpenCV cannot write MP4 files here ({path})")
    done = 0
    try:
        for _, jpeg in frames:
            image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
            if image is not None and image.shape == shape:  # skip what cannot be shown
                writer.write(image)
            done += 1
            if not next_frame():
                break
    finally:
        writer.release()
    _check_playable(path)
    return done


def _check_playable(path: Path) -> None:
    """OpenCV says nothing when the disk refuses a video (full, or a file size limit): the file
    is left cut, unplayable. Opened again to be sure; one that does not open is removed."""
    capture = cv2.VideoCapture(str(path))
    try:
        playable = capture.isOpened() and capture.get(cv2.CAP_PROP_FRAME_COUNT) > 0
    finally:
        capture.release()
    if not playable:
        size = path.stat().st_size if path.exists() else 0
        path.unlink(missing_ok=True)
        raise QuadsimError(
            f"cannot write the video {path}: the disk took {size} bytes of it and it does not play (is the disk "
            "full?); the cut file was removed"
        )
