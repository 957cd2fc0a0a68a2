"""A Foxglove layout for a run's topics: every vehicle's model, the world, the cameras (and the
depth of those that colour-map it: Studio 1.x draws a 16UC1 or 32FC1 image in grey), altitude
plots, the log, and Teleop panels on the command topic of each vehicle a Foxglove client flies.

A Foxglove 3D panel draws no topic until it is turned on, in every app from Foxglove Studio 1.x
to the current Foxglove app and Lichtblick; the layout turns on each vehicle's model markers
(/robot_markers, /alpha/robot_markers: scene.robot_markers) and /world/markers, which every one
of them draws in the vehicle's own frames, and each vehicle's LiDAR (/quad/scan, /quad/points),
drawn larger and in a colour of its own (`SCAN_DRAWING`: Studio 1.48's default, 2-pixel points
colour-mapped, cannot be seen from above a fleet). A URDF layer cannot do that in Studio 1.x (it reads
/robot_description alone, with no frame prefix), so the layout uses none. Its /robot_description
stays off for the same reason: with both on, a vehicle alone would be drawn twice.

The layout is the layout data the apps export and import ("Import from file"): `configById`
(panel id -> its settings; the id says the panel's type: `3D!quadsim`), the `layout` tree that
places the panels (a split is {direction, first, second, splitPercentage}), `globalVariables`,
`userNodes` and `playbackConfig`. Only settings that Studio 1.48 and the current app's published
layout schema (@foxglove/embed) both know are written, and a panel's title, which the layout data
keeps among the panel's settings as `foxglovePanelTitle` (the schema puts it beside them, as
`title`), and the scans' point size and colour (`SCAN_DRAWING`), which Studio 1.48 reads and the
schema leaves out (it types a topic's settings only by what every layer has: `visible`); the images use Studio 1.x's image panel (`ImageViewPanel`), which later apps turn into
their own Image panel when they import it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from quadsim.recording.contract import (
    BODY_FRAME,
    CAMERA_TOPICS,
    ODOM,
    POINTS,
    POSE,
    ROBOT_DESCRIPTION,
    ROBOT_MARKERS,
    ROSOUT,
    SCAN,
    TWIST,
    WORLD_FRAME,
    WORLD_MARKERS,
    Names,
)
from quadsim.sensors.images import COLORMAP_FAR_M, COLORMAP_NEAR_M

IMAGE_SUFFIX = CAMERA_TOPICS["image"][0]
#: a camera's depth colour-mapped (contract.depth_colormap_topic), shown beside the cameras
COLORMAP_SUFFIX = CAMERA_TOPICS["colormap"][0]
#: at most this many camera images and vehicles' altitudes in one layout (a fleet of ten with
#: two cameras each would leave each image a stamp)
MAX_IMAGES = 4
MAX_PLOTTED = 8
#: a panel's title in the layout data, among its settings (the layout schema's `title` of a panel)
TITLE_KEY = "foxglovePanelTitle"
#: the Teleop panels' buttons: one panel moves and turns, the other climbs and slides sideways
TELEOP_RATE_HZ = 20
TELEOP_SPEED_MPS = 1.0
TELEOP_YAW_RATE_RADPS = 0.5
#: the 3D view: a vehicle alone is followed from this far; a fleet is seen whole from above
FOLLOW_DISTANCE_M = 3.0
MIN_FLEET_DISTANCE_M = 8.0
#: how the 3D panel draws a LiDAR's returns (by the topic's last name): points in pixels, in one
#: colour, a 2D scan's ring yellow and a 3D scan's cloud cyan, apart from the world's red, green
#: and blue (without a `colorField` Studio 1.48 picks one and colour-maps by it instead)
SCAN_DRAWING: dict[str, dict[str, Any]] = {
    SCAN.name: {"pointSize": 5, "colorMode": "flat", "flatColor": "#ffff00ff", "colorField": "range"},
    POINTS.name: {"pointSize": 4, "colorMode": "flat", "flatColor": "#00ffffff", "colorField": "z"},
}


@dataclass(frozen=True)
class LayoutVehicle:
    """What the layout shows of one vehicle: its name ("" for a vehicle alone), the topic its
    model is drawn from (None: nothing to draw it with), its cameras' image topics (and their
    depth colour maps), where it starts (x, y, m), whether a Foxglove client flies it (a Teleop
    panel), its TF frames (base_link, its links', its cameras'), whose axes the layout hides: a fleet's forty arrows
    and the lines from `world` to each vehicle would hide the models, and its LiDAR's topics
    (a LaserScan's, a PointCloud2's), which the 3D panel draws around it."""

    name: str
    model_topic: str | None
    image_topics: tuple[str, ...] = ()
    start_xy_m: tuple[float, float] = (0.0, 0.0)
    teleop: bool = False
    frames: tuple[str, ...] = ()
    scan_topics: tuple[str, ...] = ()

    @property
    def names(self) -> Names:
        return Names(self.name)


def vehicles_from_topics(
    topics: Iterable[str],
    frames: Iterable[str] = (),
    starts: Mapping[str, tuple[float, float]] | None = None,
    teleop: Collection[str] = (),
) -> list[LayoutVehicle]:
    """The vehicles of a run, found by their odometry topics (/quad/odom, /alpha/quad/odom), in
    the order given. A vehicle's model is drawn from its /robot_markers; a recording made before
    there were any shows a vehicle alone by its /robot_description (the one URDF every app
    draws) and a fleet's vehicles not at all. `frames`: the run's TF frames (each goes to the
    vehicle whose name it starts with; all but `world` to a vehicle alone). `starts` and
    `teleop` name vehicles as `LayoutVehicle.name` does."""
    names = list(dict.fromkeys(topics))
    present = set(names)
    all_frames = [f for f in dict.fromkeys(frames) if f != WORLD_FRAME]
    vehicles = []
    for topic in names:
        if not topic.endswith(ODOM.name):
            continue
        prefix = topic[: -len(ODOM.name)]
        name = prefix.lstrip("/")
        if prefix and (prefix.count("/") != 1 or not name):
            continue  # not a vehicle's odometry under one name
        own = Names(name)
        markers, description = own.topic(ROBOT_MARKERS).name, own.topic(ROBOT_DESCRIPTION).name
        model: str | None = markers if markers in present else None
        if model is None and not name and description in present:
            model = description
        images = tuple(
            t for t in names if t.startswith(f"{prefix}/quad/") and t.endswith((IMAGE_SUFFIX, COLORMAP_SUFFIX))
        )
        start = (starts or {}).get(name, (0.0, 0.0))
        own_frames = tuple(f for f in all_frames if not name or f.startswith(f"{name}/"))
        scans = tuple(t for t in (own.topic(SCAN).name, own.topic(POINTS).name) if t in present)
        vehicles.append(LayoutVehicle(name, model, images, start, name in teleop, own_frames, scans))
    return vehicles


def foxglove_layout(vehicles: Sequence[LayoutVehicle], world: bool = True) -> dict[str, Any]:
    """The layout data for `vehicles` (see the module's docstring): the 3D panel on the left,
    beside it the cameras, the Teleop panels, the altitudes and the log. `world`: the run has a
    world (its /world/markers are turned on)."""
    panels: dict[str, dict[str, Any]] = {"3D!quadsim": _three_dee(vehicles, world)}
    right: list[str] = []
    images = [topic for vehicle in vehicles for topic in vehicle.image_topics][:MAX_IMAGES]
    for i, topic in enumerate(images):
        panel = f"ImageViewPanel!image{i}"
        panels[panel] = {
            "cameraTopic": topic,
            "enabledMarkerTopics": [],
            "synchronize": False,
            "transformMarkers": False,
            "mode": "fit",
        }
        if topic.endswith(COLORMAP_SUFFIX):  # the scale, which the image cannot say
            camera = topic.removesuffix(COLORMAP_SUFFIX).rpartition("/")[2].removesuffix("_camera")
            scale = f"turbo, log {COLORMAP_NEAR_M:g}-{COLORMAP_FAR_M:g} m, black: none"
            panels[panel][TITLE_KEY] = f"{camera} depth ({scale})"
        right.append(panel)
    for i, vehicle in enumerate(v for v in vehicles if v.teleop):
        for kind, (title, buttons) in _TELEOP_BUTTONS.items():
            panel = f"Teleop!{kind}{i}"
            panels[panel] = {
                "topic": vehicle.names.topic(TWIST).name,
                "publishRate": TELEOP_RATE_HZ,
                **{button: {"field": field, "value": value} for button, (field, value) in buttons.items()},
                TITLE_KEY: f"{vehicle.name or 'Teleop'}: {title}",
            }
            right.append(panel)
    panels["Plot!altitude"] = _altitude_plot(vehicles)
    panels["RosOut!log"] = {"searchTerms": [], "minLogLevel": 1, "preload": False, "topicToRender": ROSOUT.name}
    right += ["Plot!altitude", "RosOut!log"]
    return {
        "configById": panels,
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1.0},
        "layout": {"direction": "row", "first": "3D!quadsim", "second": _column(right), "splitPercentage": 62},
    }


def layout_json(layout: Mapping[str, Any]) -> str:
    """The layout as the text of a .json file (keys in the order written)."""
    return json.dumps(layout, indent=2) + "\n"


_TELEOP_BUTTONS = {
    "move": (
        "forward, back, turn",
        {
            "upButton": ("linear-x", TELEOP_SPEED_MPS),
            "downButton": ("linear-x", -TELEOP_SPEED_MPS),
            "leftButton": ("angular-z", TELEOP_YAW_RATE_RADPS),
            "rightButton": ("angular-z", -TELEOP_YAW_RATE_RADPS),
        },
    ),
    "climb": (
        "climb, descend, sideways",
        {
            "upButton": ("linear-z", TELEOP_SPEED_MPS),
            "downButton": ("linear-z", -TELEOP_SPEED_MPS),
            "leftButton": ("linear-y", TELEOP_SPEED_MPS),
            "rightButton": ("linear-y", -TELEOP_SPEED_MPS),
        },
    ),
}


def _three_dee(vehicles: Sequence[LayoutVehicle], world: bool) -> dict[str, Any]:
    """The 3D panel: a vehicle alone followed (its position, not its heading), a fleet seen from
    above its start positions; each model and the world turned on, the vehicles' frames hidden
    (the apps name a frame's settings `frame:NAME`)."""
    topics = {v.model_topic: {"visible": True} for v in vehicles if v.model_topic is not None}
    if world:
        topics[WORLD_MARKERS.name] = {"visible": True}
    for vehicle in vehicles:
        for topic in vehicle.scan_topics:
            drawing = next(d for name, d in SCAN_DRAWING.items() if topic.endswith(name))
            topics[topic] = {"visible": True, **drawing}
    if len(vehicles) == 1:
        follow, target, distance = vehicles[0].names.frame(BODY_FRAME), (0.0, 0.0), FOLLOW_DISTANCE_M
    else:
        xs = [v.start_xy_m[0] for v in vehicles] or [0.0]
        ys = [v.start_xy_m[1] for v in vehicles] or [0.0]
        target = ((min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2)
        spread = math.hypot(max(xs) - min(xs), max(ys) - min(ys))
        follow, distance = WORLD_FRAME, max(MIN_FLEET_DISTANCE_M, 2.0 * spread)
    return {
        "cameraState": {
            "distance": round(distance, 2),
            "perspective": True,
            "phi": 50.0,
            "thetaOffset": 30.0,
            "targetOffset": [round(target[0], 3), round(target[1], 3), 1.0],
            "target": [0.0, 0.0, 0.0],
            "targetOrientation": [0.0, 0.0, 0.0, 1.0],
            "fovy": 45.0,
            "near": 0.01,
            "far": 5000.0,
        },
        "followMode": "follow-position",
        "followTf": follow,
        "scene": {"transforms": {"showLabel": False}},
        "transforms": {f"frame:{frame}": {"visible": False} for v in vehicles for frame in v.frames},
        "topics": topics,
        "layers": {},
    }


def _altitude_plot(vehicles: Sequence[LayoutVehicle]) -> dict[str, Any]:
    """Each vehicle's altitude (its pose's z), named after it."""
    paths = [
        {
            "value": f"{v.names.topic(POSE).name}.pose.position.z",
            "enabled": True,
            "timestampMethod": "receiveTime",
            "label": f"{v.name or 'vehicle'} z (m)",
        }
        for v in vehicles[:MAX_PLOTTED]
    ]
    return {
        "paths": paths,
        TITLE_KEY: "altitude (m)",
        "showLegend": True,
        "legendDisplay": "floating",
        "showPlotValuesInLegend": True,
        "showXAxisLabels": True,
        "showYAxisLabels": True,
        "isSynced": True,
        "xAxisVal": "timestamp",
        "sidebarDimension": 240,
    }


def _column(panels: Sequence[str]) -> str | dict[str, Any]:
    """`panels` one above the other, each as tall as the others."""
    if len(panels) == 1:
        return panels[0]
    half = len(panels) // 2
    return {
        "direction": "column",
        "first": _column(panels[:half]),
        "second": _column(panels[half:]),
        "splitPercentage": round(100 * half / len(panels), 2),
    }
