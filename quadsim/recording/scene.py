"""The latched messages that describe the scene to a viewer: the vehicle's URDF
(/robot_description), the world's floor and landmarks (/world/markers) and where every URDF link
sits on the body (/tf_static), so Foxglove or RViz draw the vehicle and the world, not only axes.

The URDF is published as its file says, so a viewer needs none of quadsim's files: the shipped
airframes are drawn with primitive shapes (boxes, cylinders) only. A URDF of one's own may name
mesh files (the loader accepts paths relative to the URDF); those become absolute `file://` URIs,
which RViz and Foxglove's desktop app open on the machine that has the files. `package://` would
need a ROS package around the meshes, and neither viewer reads meshes embedded in the URDF.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from quadsim.core.kinematics import quaternion_from_matrix
from quadsim.physics.world_spec import Shape, WorldSpec
from quadsim.recording import cdr
from quadsim.recording.contract import BODY_FRAME, WORLD_FRAME
from quadsim.vehicle.params import VehicleParams

#: the floor's marker: a thin slab whose top is z = 0, in the grey of the floor's tiles
FLOOR_THICKNESS_M = 0.01
FLOOR_RGBA = (0.55, 0.55, 0.55, 1.0)
FLOOR_NAMESPACE = "floor"
UPRIGHT = (0.0, 0.0, 0.0, 1.0)


def robot_description(urdf_path: Path) -> str:
    """The URDF text for /robot_description: as written, with mesh file names made `file://`
    URIs (see the module's docstring)."""
    text = urdf_path.read_text(encoding="utf-8")
    root = ET.fromstring(text)
    meshes = list(root.iter("mesh"))
    if not meshes:
        return text  # comments and layout kept
    folder = urdf_path.resolve().parent
    for mesh in meshes:
        mesh.set("filename", (folder / mesh.get("filename", "")).as_uri())
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode")


def world_markers(world: WorldSpec, ns: int) -> list[cdr.Marker]:
    """The floor (id 0, namespace "floor") and each landmark (id 1.., namespace its name), in
    the `world` frame, stamped at `ns`: shapes, sizes and colours as the world file gives them."""
    size = world.floor.size_m
    markers = [
        cdr.Marker(
            ns,
            WORLD_FRAME,
            FLOOR_NAMESPACE,
            0,
            cdr.MarkerType.CUBE,
            (0.0, 0.0, -FLOOR_THICKNESS_M / 2),
            UPRIGHT,
            (size, size, FLOOR_THICKNESS_M),
            FLOOR_RGBA,
        )
    ]
    for i, landmark in enumerate(world.landmarks, start=1):
        sx, sy, sz = landmark.size_m
        if landmark.shape is Shape.BOX:
            kind, scale = cdr.MarkerType.CUBE, (sx, sy, sz)
        elif landmark.shape is Shape.CYLINDER:  # radius, radius, height; along z, as PyBullet has it
            kind, scale = cdr.MarkerType.CYLINDER, (2 * sx, 2 * sy, sz)
        else:  # a sphere: its radius
            kind, scale = cdr.MarkerType.SPHERE, (2 * sx, 2 * sx, 2 * sx)
        markers.append(
            cdr.Marker(
                ns, WORLD_FRAME, landmark.name, i, kind, landmark.position_m, UPRIGHT, scale, landmark.color_rgba
            )
        )
    return markers


def link_transforms(vehicle: VehicleParams) -> list[cdr.TransformStamped]:
    """base_link -> every other URDF link (stamped 0: the caller stamps them)."""
    return [
        cdr.TransformStamped(0, BODY_FRAME, link.link_name, link.position_m, quaternion_from_matrix(link.rotation))
        for link in vehicle.link_frames
    ]
