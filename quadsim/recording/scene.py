"""The latched messages that describe the scene to a viewer: the vehicle's URDF
(/robot_description), the world's floor and landmarks (/world/markers) and where every URDF link
sits on the body (/tf_static), so Foxglove or RViz draw the vehicle and the world, not only axes.

The URDF is published as its file says, so a viewer needs none of quadsim's files: the shipped
airframes are drawn with primitive shapes (boxes, cylinders) only. A URDF of one's own may name
mesh files (the loader accepts paths relative to the URDF). Recordings and the Foxglove server
carry each one inline, as a `data:` URL with its media type (model/stl, model/obj,
model/vnd.collada+xml, model/gltf-binary): browser apps (Foxglove, Lichtblick) fetch those like
any URL, where a `file://` URL is out of a web page's reach, and the file plays on any machine.
The ROS 2 bridge publishes `file://` URLs instead, since RViz's resource retriever reads files
and not `data:` URLs. A mesh too large to inline (see MAX_INLINE_MESH_BYTES), or one that names
further files (a .gltf's buffers, a COLLADA file's textures are not followed), stays `file://`.
"""

from __future__ import annotations

import base64
import logging
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
#: the media types browser apps load meshes by (a data: URL has no file name to go by)
MESH_MEDIA_TYPES = {
    ".stl": "model/stl",
    ".obj": "model/obj",
    ".dae": "model/vnd.collada+xml",
    ".glb": "model/gltf-binary",
}
#: a mesh larger than this stays a file:// URL (a latched message is sent to every client that joins)
MAX_INLINE_MESH_BYTES = 8 * 1024 * 1024
#: and so do the meshes after this much has been inlined in one description
MAX_INLINE_TOTAL_BYTES = 32 * 1024 * 1024

log = logging.getLogger(__name__)


def robot_description(urdf_path: Path, inline_meshes: bool = True) -> str:
    """The URDF text for /robot_description: as written, with each mesh file name made a
    `data:` URL holding the mesh (`inline_meshes`, within the size limits) or a `file://` URL
    (see the module's docstring)."""
    text = urdf_path.read_text(encoding="utf-8")
    root = ET.fromstring(text)
    meshes = list(root.iter("mesh"))
    if not meshes:
        return text  # comments and layout kept
    folder = urdf_path.resolve().parent
    inlined: dict[Path, str] = {}  # a mesh named by several links is read once
    budget = MAX_INLINE_TOTAL_BYTES
    for mesh in meshes:
        path = folder / mesh.get("filename", "")
        url = inlined.get(path)
        if url is None and inline_meshes:
            url = _data_url(path, budget)
            if url is not None:
                inlined[path] = url
                budget -= path.stat().st_size
        mesh.set("filename", url or path.as_uri())
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode")


def _data_url(path: Path, budget_bytes: int) -> str | None:
    """`path` as a data: URL, or None (said once in the log) where it cannot or should not be."""
    media_type = MESH_MEDIA_TYPES.get(path.suffix.lower())
    if media_type is None:
        log.warning("mesh %s stays a file:// URL: only %s are inlined", path.name, ", ".join(MESH_MEDIA_TYPES))
        return None
    try:
        size = path.stat().st_size
        if size > min(MAX_INLINE_MESH_BYTES, budget_bytes):
            log.warning("mesh %s (%.1f MB) stays a file:// URL: browser apps will not load it", path.name, size / 1e6)
            return None
        data = path.read_bytes()[:MAX_INLINE_MESH_BYTES]
    except OSError as exc:
        log.warning("mesh %s stays a file:// URL: %s", path.name, exc.strerror or exc)
        return None
    return f"data:{media_type};base64,{base64.b64encode(data).decode('ascii')}"


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
