"""`quadsim layout`: a Foxglove layout file for a recording, a fleet file's live run, or a live
run of one vehicle, to import in one step (recording/foxglove_layout.py says what it shows)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from quadsim.apps.commands import add_command_parser
from quadsim.core.files import write_whole
from quadsim.errors import QuadsimError
from quadsim.recording.contract import BODY_FRAME, TF, TF_STATIC, WORLD_FRAME, Names
from quadsim.recording.fanout import TopicFanout
from quadsim.recording.foxglove_layout import LayoutVehicle, foxglove_layout, layout_json, vehicles_from_topics

#: what `layout` with no source writes, in the current folder
DEFAULT_NAME = "quadsim.layout.json"
#: the most TF messages read from a recording to find its frames (they are all in the first few)
MAX_TF_MESSAGES = 64


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command_parser(
        sub,
        "layout",
        description="Write a Foxglove layout (JSON) that shows every vehicle's model, the world, the "
        "cameras, each vehicle's altitude and the log, with Teleop panels on the command topic of each "
        "vehicle a Foxglove client flies. In the Foxglove app (Studio 1.x, the current app, Lichtblick): "
        "Layouts -> Import from file. For a recording, a fleet file's live run, or (with no SOURCE) a "
        "live run of one vehicle (run --input foxglove, fly --foxglove).",
    )
    p.add_argument(
        "source",
        type=Path,
        nargs="?",
        metavar="FILE.mcap|FLEET.toml",
        help="a recording (or a ros2 bag's folder holding one), or a fleet file for its live run; "
        "none: one vehicle flown live, with --cameras",
    )
    p.add_argument(
        "-o",
        "--out",
        type=Path,
        metavar="FILE.json",
        help=f"where to write it, never over a file that is there (default: beside SOURCE as NAME.layout.json; "
        f"with no SOURCE, ./{DEFAULT_NAME})",
    )
    p.add_argument(
        "--cameras",
        default="front,floor",
        metavar="LIST",
        help="with no SOURCE: the cameras the run has, as run's --cameras (default front,floor)",
    )


def main(args: argparse.Namespace) -> int:
    source: Path | None = args.source
    if source is None:
        vehicles = _one_vehicle(args.cameras)
        out = args.out or Path(DEFAULT_NAME)
    elif source.suffix.lower() == ".toml":
        vehicles = _fleet_file(source)
        out = args.out or source.with_name(f"{source.stem}.layout.json")
    else:
        from quadsim.recording.mcap_scan import bag_file

        source = bag_file(source)
        vehicles = _recording(source)
        out = args.out or source.with_name(f"{source.stem}.layout.json")
    if out.suffix.lower() != ".json":
        raise QuadsimError(f"--out {out}: a layout is a .json file")
    text = layout_json(foxglove_layout(vehicles)).encode()
    exists = f"{out} already exists; choose another --out (nothing is overwritten)"
    try:
        write_whole(out, lambda fh: fh.write(text), exists)
    except OSError as exc:
        raise QuadsimError(f"cannot write {out}: {exc.strerror or exc}; nothing was written") from None
    shown = ", ".join(v.name or "the vehicle" for v in vehicles if v.model_topic) or "no vehicle's model"
    print(f"wrote {out}: {shown}; in Foxglove: Layouts -> Import from file -> {out.name}")
    missing = [v.name for v in vehicles if v.model_topic is None]
    if missing:
        print(
            f"note: {', '.join(missing)} have no /NAME/robot_markers in this recording (made before quadsim drew them)"
        )
    return 0


def _recording(path: Path) -> list[LayoutVehicle]:
    """The vehicles of a recording: its topics, its TF frames, where its vehicles started."""
    from quadsim.recording.reader import RecordingReader

    with RecordingReader(path) as reader:
        frames: list[str] = []
        for topic in (TF_STATIC.name, TF.name):
            for i, (_, message) in enumerate(reader.messages(topic)):
                frames += [t.child_frame_id for t in message.transforms]
                if i >= MAX_TF_MESSAGES:
                    break
        description = reader.description
        runs = description.fleet if description is not None and description.fleet else ()
        starts = {name: (d.config.start.x_m, d.config.start.y_m) for name, d in runs}
        return vehicles_from_topics(reader.topics, frames, starts)


def _fleet_file(path: Path) -> list[LayoutVehicle]:
    """The vehicles of a fleet file's live run, with the topics and frames the run will have."""
    from quadsim.sim.fleet_file import load_fleet_file

    fleet = load_fleet_file(path)
    fanout = TopicFanout(physics_hz=240)
    for entry in fleet.vehicles:
        images = (entry.depth, entry.segmentation, entry.depth_colormap)
        _add_vehicle(fanout, Names(entry.name), entry.urdf, entry.cameras, images)
    teleop = {e.name for e in fleet.vehicles if e.input == "foxglove"}
    starts = {e.name: (e.start.x_m, e.start.y_m) for e in fleet.vehicles}
    return _from_fanout(fanout, teleop, starts)


def _one_vehicle(cameras: str) -> list[LayoutVehicle]:
    """One vehicle (the shipped quad) flown live with `cameras`, from a Foxglove Teleop panel."""
    wanted = tuple(c.strip() for c in cameras.split(",") if c.strip() and c.strip() != "none")
    fanout = TopicFanout(physics_hz=240)
    _add_vehicle(fanout, Names(), None, wanted)
    return _from_fanout(fanout, {""}, {})


def _add_vehicle(
    fanout: TopicFanout,
    names: Names,
    urdf: Path | None,
    cameras: Sequence[str],
    images: tuple[Sequence[str], Sequence[str], Sequence[str]] = ((), (), ()),
) -> None:
    """A vehicle with `cameras` and the `images` (depth, segmentation, depth colour map: camera
    names, as a fleet file's entry has them) added to `fanout`."""
    from quadsim.sensors.camera import default_cameras, with_images
    from quadsim.vehicle.params import load_vehicle

    vehicle = load_vehicle(urdf)
    specs = {spec.name: spec for spec in default_cameras()}
    unknown = sorted(set(cameras) - set(specs))
    if unknown:
        raise QuadsimError(f"--cameras: no camera {', '.join(unknown)} (there are {', '.join(specs)})")
    chosen = with_images([specs[name] for name in cameras], *images, ("depth", "segmentation", "depth_colormap"))
    mounts = [(spec, vehicle.camera_mount(spec.link_name)) for spec in chosen]
    fanout.add_vehicle(names, mounts, vehicle)


def _from_fanout(fanout: TopicFanout, teleop: set[str], starts: dict[str, tuple[float, float]]) -> list[LayoutVehicle]:
    frames = [WORLD_FRAME]
    for vehicle in fanout.vehicles:
        frames += [vehicle.names.frame(BODY_FRAME), *(s.child_frame_id for s in vehicle.static_transforms)]
    return vehicles_from_topics([t.name for t in fanout.topics], frames, starts, teleop)
