"""The latched messages that describe the scene to a viewer: the vehicle's URDF
(/robot_description) and the same model as markers (/robot_markers), the world's floor and
landmarks (/world/markers) and where every URDF link sits on the body (/tf_static), so Foxglove or
RViz draw the vehicle and the world, not only axes.

The markers are for the viewers that cannot draw a fleet's URDFs: Foxglove Studio 1.x draws a URDF
from /robot_description only (not /alpha/robot_description, and with no frame prefix), while
every Foxglove app, Lichtblick and RViz draw a MarkerArray in whatever frames it names. Each URDF
visual (a link's collision shapes where it has no visual, as Foxglove does) becomes one marker in
its link's frame under the vehicle's name, locked to that frame so that it flies with it.

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
import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

from quadsim.core.kinematics import Quat, Vec3, matrix_from_rpy, quaternion_from_matrix
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
#: a vehicle's model as markers: what a visual without a colour is drawn in, and the most markers
#: one vehicle sends (a latched message goes to every client that joins)
ROBOT_RGBA = (0.7, 0.7, 0.7, 1.0)
ROBOT_NAMESPACE = "robot"
MAX_ROBOT_MARKERS = 1000
#: a fleet vehicle's name over it: this high above its base_link, text this tall (m)
LABEL_NAMESPACE = "label"
LABEL_HEIGHT_M = 0.35
LABEL_SIZE_M = 0.25
LABEL_RGBA = (1.0, 1.0, 1.0, 1.0)
#: visualization_msgs/msg/Marker MESH_RESOURCE
MESH_RESOURCE = 10

log = logging.getLogger(__name__)


def robot_description(urdf_path: Path, inline_meshes: bool = True) -> str:
    """The URDF text for /robot_description: as written, with each mesh file name made a
    `data:` URL holding the mesh (`inline_meshes`, within the size limits) or a `file://` URL
    (see the module's docstring)."""
    text = urdf_path.read_text(encoding="utf-8")
    root = ET.fromstring(text)
    if not _name_meshes_by_url(root, urdf_path, inline_meshes):
        return text  # comments and layout kept
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode")


def _name_meshes_by_url(root: ET.Element, urdf_path: Path, inline_meshes: bool) -> bool:
    """Each <mesh>'s file name in `root` made a data: URL (`inline_meshes`, within the size
    limits) or a file:// URL; False where the URDF has no mesh."""
    meshes = list(root.iter("mesh"))
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
    return bool(meshes)


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


def robot_markers(
    urdf_path: Path, frame: Callable[[str], str] = str, inline_meshes: bool = True, label: str = ""
) -> list[cdr.Marker]:
    """The vehicle's model as markers (stamped 0: the caller stamps them): one per URDF visual
    (a link's collision shapes where it has none), in the frame `frame` names for its link (a
    fleet vehicle's `alpha/rotor_1`), frame-locked, ids 0.. in the URDF's order, namespace
    "robot". Boxes, cylinders and spheres as such; a mesh as MESH_RESOURCE with the URL
    /robot_description gives it (`inline_meshes`: data:, else file://). A visual whose geometry
    cannot be read is left out (said once in the log), as a viewer would leave it. With a
    `label` (a fleet vehicle's name), last comes that text above the vehicle (namespace "label"),
    so that one can tell a fleet's vehicles apart."""
    root = ET.fromstring(urdf_path.read_text(encoding="utf-8"))
    _name_meshes_by_url(root, urdf_path, inline_meshes)
    colours = _material_colours(root)
    markers: list[cdr.Marker] = []
    skipped: list[str] = []
    for link in root.iter("link"):
        link_name = link.get("name", "")
        parts = link.findall("visual") or link.findall("collision")
        for part in parts:
            marker = _part_marker(part, frame(link_name), len(markers), colours)
            if marker is None:
                skipped.append(link_name)
            elif len(markers) < MAX_ROBOT_MARKERS:
                markers.append(marker)
    if skipped:
        log.warning("%s: %d shapes of links %s are not drawn as markers", urdf_path.name, len(skipped), skipped[:3])
    if len(markers) == MAX_ROBOT_MARKERS:
        log.warning("%s: only its first %d shapes are drawn as markers", urdf_path.name, MAX_ROBOT_MARKERS)
    if label:
        markers.append(
            cdr.Marker(
                0,
                frame(BODY_FRAME),
                LABEL_NAMESPACE,
                len(markers),
                cdr.MarkerType.TEXT_VIEW_FACING,
                (0.0, 0.0, LABEL_HEIGHT_M),
                UPRIGHT,
                (0.0, 0.0, LABEL_SIZE_M),
                LABEL_RGBA,
                frame_locked=True,
                text=label,
            )
        )
    return markers


def _material_colours(root: ET.Element) -> dict[str, tuple[float, ...]]:
    """The colours of the URDF's named materials (those declared at the top, with a <color>)."""
    colours = {}
    for material in root.findall("material"):
        rgba = _numbers(material.find("color"), "rgba", 4)
        if rgba is not None:
            colours[material.get("name", "")] = rgba
    return colours


def _numbers(elem: ET.Element | None, key: str, count: int, default: str | None = None) -> tuple[float, ...] | None:
    """`count` finite numbers from attribute `key` of `elem` (or `default` where it is absent),
    or None where they are not that."""
    text = default if elem is None else elem.get(key, default)
    try:
        values = tuple(float(v) for v in (text or "").split())
    except ValueError:
        return None
    return values if len(values) == count and all(math.isfinite(v) for v in values) else None


def _part_marker(
    part: ET.Element, frame_id: str, marker_id: int, colours: dict[str, tuple[float, ...]]
) -> cdr.Marker | None:
    """A <visual> or <collision> as a marker in `frame_id`, or None where its geometry is not
    one of URDF's four shapes with sound numbers."""
    origin = part.find("origin")
    xyz = _numbers(origin, "xyz", 3, "0 0 0")
    rpy = _numbers(origin, "rpy", 3, "0 0 0")
    geometry = part.find("geometry")
    shape = geometry[0] if geometry is not None and len(geometry) else None
    if xyz is None or rpy is None or shape is None:
        return None
    mesh = ""
    if shape.tag == "box":
        kind, scale = cdr.MarkerType.CUBE, _numbers(shape, "size", 3)
    elif shape.tag == "cylinder":  # along z, as a marker's cylinder is
        radius, length = _numbers(shape, "radius", 1), _numbers(shape, "length", 1)
        kind = cdr.MarkerType.CYLINDER
        scale = None if radius is None or length is None else (2 * radius[0], 2 * radius[0], length[0])
    elif shape.tag == "sphere":
        radius = _numbers(shape, "radius", 1)
        kind, scale = cdr.MarkerType.SPHERE, None if radius is None else (2 * radius[0],) * 3
    elif shape.tag == "mesh":
        kind, scale, mesh = MESH_RESOURCE, _numbers(shape, "scale", 3, "1 1 1"), shape.get("filename", "")
    else:
        return None
    if scale is None:
        return None
    material = part.find("material")
    rgba = _numbers(material.find("color"), "rgba", 4) if material is not None else None
    if rgba is None and material is not None:
        rgba = colours.get(material.get("name", ""))
    position: Vec3 = (xyz[0], xyz[1], xyz[2])
    orientation: Quat = quaternion_from_matrix(matrix_from_rpy(*rpy))
    return cdr.Marker(
        0,
        frame_id,
        ROBOT_NAMESPACE,
        marker_id,
        kind,
        position,
        orientation,
        (scale[0], scale[1], scale[2]),
        rgba or ROBOT_RGBA,
        frame_locked=True,
        mesh_resource=mesh,
        mesh_use_embedded_materials=bool(mesh) and rgba is None,  # a mesh keeps its own colours
    )


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
