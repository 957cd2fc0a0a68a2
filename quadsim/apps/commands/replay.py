"""`quadsim replay`: a recording played back in the window, summarised, exported as videos and a
plot, served live to Foxglove and ROS 2 as it plays, or flown again (--resim)."""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from quadsim.apps.commands import add_command_parser
from quadsim.apps.flight_plot import export_plot, require_matplotlib
from quadsim.apps.options import (
    PLOT_SUFFIXES,
    add_live_options,
    check_output_dir,
    check_output_file,
    has_display,
    live_outputs,
    number,
    recordings_default,
    stopped_by_signal,
    warn,
    window_size,
)
from quadsim.apps.regression import DEFAULT_TOLERANCE_M, DEFAULT_TOLERANCE_RAD
from quadsim.apps.replay_export import export_mp4, mp4_paths, mp4_target, summary_lines
from quadsim.apps.window.replay import ReplayApp
from quadsim.apps.window.x11_guard import EXIT_DISPLAY_LOST
from quadsim.errors import QuadsimError
from quadsim.live.playback import RecordingFeed
from quadsim.recording.flight import load_flight, load_flights
from quadsim.recording.mcap_scan import bag_file
from quadsim.session.pacing import RealTimePacer
from quadsim.session.progress import ProgressBar
from quadsim.session.stopping import stop_requested

if TYPE_CHECKING:
    from quadsim.recording.flight import RecordedFlight


#: live playback's ticks are nanoseconds of the recording; it plays this much at a time
NS_PER_S, PLAY_TICK_NS = 1_000_000_000, 10_000_000


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command_parser(
        sub,
        "replay",
        description="Play a recording back in the teleop window (both cameras, the map with the whole "
        "track, the HUD; Space play/pause, arrows seek and speed, click the timeline). "
        "--headless prints a summary and can export MP4 videos and a plot. --resim rebuilds "
        "the vehicle, controller and settings from the recording, flies its commands again, "
        "records the new flight and reports how far it is from the recorded one. A recording that lost commands "
        "or states (a run killed mid-write) is refused, as info refuses it: recover it first.",
    )
    p.add_argument("file", type=Path, metavar="FILE.mcap", help="the recording, or a ros2 bag's folder holding one")
    p.add_argument("--headless", action="store_true", help="no window: print a summary")
    p.add_argument(
        "--mp4",
        type=Path,
        default=None,
        metavar="DIR|NAME.mp4",
        help="export each camera stream as MP4: into DIR (RECORDING_front.mp4, ...), or beside NAME.mp4 as "
        "NAME_front.mp4, NAME_floor.mp4",
    )
    p.add_argument(
        "--plot",
        type=Path,
        default=None,
        metavar="FILE.png",
        help="draw the track and the commands against the state to a PNG (or .svg, .pdf)",
    )
    p.add_argument("--resim", action="store_true", help="fly the recorded commands again and compare")
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="DIR|FILE",
        help=f"with --resim: where the new flight is recorded (default: {recordings_default()})",
    )
    p.add_argument("--no-record", action="store_true", help="with --resim: do not record the new flight")
    p.add_argument(
        "--speed",
        type=number(0.25, 16.0, "a speed factor"),
        default=1.0,
        help="playback speed, 0.25 to 16 (default 1)",
    )
    p.add_argument("--loop", action="store_true", help="start again at the end")
    p.add_argument(
        "--depth",
        action="store_true",
        help="also load the cameras' depth images, colour-mapped: the window shows them in place of the "
        "cameras' (V switches), --mp4 exports them too (RECORDING_front_depth.mp4)",
    )
    p.add_argument(
        "--vehicle",
        metavar="NAME",
        help="in a fleet's recording, the vehicle whose summary, plot and videos are shown (default: the first; "
        "--plot draws the others' tracks too, --resim re-flies them all)",
    )
    p.add_argument("--window", default="1280x720", metavar="WxH", help="initial window size (default 1280x720)")
    add_live_options(p, "the recorded messages, as they are played (put FILE first),", flown=False)


def main(args: argparse.Namespace) -> int:

    args.file = bag_file(args.file)
    size = window_size(args.window)
    if args.plot is not None:
        check_output_file("--plot", args.plot, PLOT_SUFFIXES)
        require_matplotlib()  # said before the videos are encoded, not after
    mp4_folder = None
    if args.mp4 is not None and not args.resim:
        mp4_folder = mp4_target(args.mp4, args.file)[0]
        made = not mp4_folder.exists()
        check_output_dir("--mp4", mp4_folder)
    if (args.foxglove is not None or args.ros2) and args.resim:
        option = "--foxglove" if args.foxglove is not None else "--ros2"
        raise QuadsimError(f"{option} plays the recording as it is; with --resim nothing would be played (drop one)")
    if args.resim and (args.mp4 is not None or args.plot is not None):
        option = "--mp4" if args.mp4 is not None else "--plot"
        raise QuadsimError(
            f"{option} exports the recording as it is; with --resim nothing would be exported (drop one, "
            "or replay the new flight's recording)"
        )
    if not args.resim and (args.out is not None or args.no_record):
        option = "--out" if args.out is not None else "--no-record"
        raise QuadsimError(f"{option} is for the new flight of --resim; without --resim nothing is recorded")
    try:
        flight = load_flight(args.file, args.vehicle, depth=args.depth and not args.resim)
        lost = flight.lost_for_resim()
        if lost is not None:  # commands or states are missing (a run killed mid-write): said as `info` says it
            raise QuadsimError(flight.damage_report or f"{args.file}: {lost}")
        if mp4_folder is not None:  # refused before anything is encoded or printed
            mp4_paths(args.mp4, flight)
    except QuadsimError:
        if mp4_folder is not None and made:
            with contextlib.suppress(OSError):  # made for the videos, empty: not left behind
                mp4_folder.rmdir()
        raise
    if args.resim:
        return _resim(args, flight)
    if args.ros2:  # the missing extra said before the summary, not after it
        from quadsim.live.ros2 import cyclonedds

        cyclonedds()
    warn(flight.warnings(), args.file)
    headless = args.headless or args.mp4 is not None or args.plot is not None
    if not headless and not has_display():
        print(
            "No display found: printing the summary instead (use --headless, --mp4 DIR or --plot FILE.png "
            "for pictures, or --resim to fly it again)."
        )
        headless = True
    return _headless(args, flight) if headless else _window(args, flight, size)


def _resim(args: argparse.Namespace, flight: RecordedFlight) -> int:
    """Fly the recorded commands again and say how far the new flight is from the recorded one."""
    from quadsim.session.resim import resimulate

    bar = ProgressBar(flight.duration_s, "re-flying")
    flights = load_flights(args.file) if flight.vehicle else flight  # a fleet's: every vehicle again, together
    report = resimulate(
        flights, args.out, not args.no_record, DEFAULT_TOLERANCE_M, DEFAULT_TOLERANCE_RAD, progress=bar.update
    )
    bar.close()
    for line in report.lines():
        print(line)
    warn(flight.warnings(), args.file)
    return 0


def _headless(args: argparse.Namespace, flight: RecordedFlight) -> int:
    """The summary, then the videos and the plot asked for, then live playback if asked for."""

    for line in summary_lines(flight):
        print(line)
    if args.mp4 is not None:
        code = _export_videos(args.mp4, flight)
        if code:
            return code
    if args.plot is not None:
        others = None
        if flight.vehicle:  # a fleet's: the others' tracks too
            others = {n: f.states for n, f in load_flights(args.file).items() if n != flight.vehicle}
        print(f"plot        {export_plot(flight, args.plot, others)}")
    if args.foxglove is not None or args.ros2:
        return _play_live(args)
    return 0


def _export_videos(folder: Path, flight: RecordedFlight) -> int:
    """Each camera stream as a video, with progress; a signal ends each at its next frame (exit code)."""

    bar = ProgressBar(sum(len(frames) for frames in flight.frames.values()), "encoding video", unit="frames")
    videos = export_mp4(flight, folder, progress=lambda done, _: bar.update(done), stop=stop_requested)
    bar.close()
    for video in videos:
        print(video.line())
    if any(v.frames < v.of for v in videos):  # a signal stopped the encoding
        return stopped_by_signal("; each video is whole and ends where the encoding stopped") or 0
    return 0


def _window(args: argparse.Namespace, flight: RecordedFlight, size: tuple[int, int]) -> int:
    """The playback window, until Esc, a signal or a lost display."""

    live = live_outputs(args)
    try:
        feed = RecordingFeed(args.file, live) if live else None
        others = None
        if flight.vehicle:  # a fleet's: the others on the map
            others = {n: f for n, f in load_flights(args.file).items() if n != flight.vehicle}
        with ReplayApp(flight, size, speed=args.speed, loop=args.loop, feed=feed, others=others) as app:
            print("replaying; press H or F1 in the window for the keys, Esc to quit")
            app.run(stop=stop_requested)  # a signal ends the playback at its next frame
    finally:
        for output in live:
            output.close()
    if app.display_lost is not None:
        print(f"the window's display was lost ({app.display_lost})", file=sys.stderr)
        return EXIT_DISPLAY_LOST
    return stopped_by_signal() or 0


def _play_live(args: argparse.Namespace) -> int:
    """replay --foxglove/--ros2 with no window: play the recording live in real time (times
    --speed), once or --loop, until its end or Ctrl-C."""
    live = live_outputs(args)
    try:
        feed = RecordingFeed(args.file, live)
        print(
            f"playing {len(feed.messages)} messages on {len(feed.topics)} topics ({feed.end_ns / 1e9:.1f} s) "
            f"at {args.speed:g}x{', looping' if args.loop else ''}; Ctrl-C stops",
            flush=True,
        )
        pacer = RealTimePacer(NS_PER_S, None, speed=args.speed)  # ticks: ns of the recording; catches up
        t_ns = 0
        while not stop_requested():
            pacer.wait(t_ns + PLAY_TICK_NS, stop_requested)
            t_ns += pacer.steps_for_frame(t_ns)
            if t_ns > feed.end_ns:
                feed.play_to(feed.end_ns)
                if not args.loop:
                    break
                t_ns = 0
                pacer.rebase(0)
            feed.play_to(t_ns)
    finally:
        for output in live:
            output.close()
    print(f"played {feed.played} messages")
    return stopped_by_signal() or 0
