"""Builds the world of a WorldSpec (floor, landmarks) and the vehicle body in a PyBullet client.

Shared by the physics world and the render workers, so both hold the same scene.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

from quadsim.core.files import write_whole
from quadsim.errors import ConfigError
from quadsim.physics.pybullet_quiet import c_output_silenced, pb
from quadsim.physics.world_spec import Shape, WorldSpec
from quadsim.vehicle.meshes import cache_dir
from quadsim.vehicle.params import VehicleParams


def _floor_mesh(size_m: float, tile_m: float) -> tuple[list, list, list]:
    """A square grid of quads, one per texture tile (at most 40 x 40): TinyRenderer clips
    large triangles that reach behind the camera poorly, and smaller ones render faster."""
    n = max(1, min(40, round(size_m / tile_m)))
    half, step = size_m / 2.0, size_m / n
    vertices, uvs, indices = [], [], []
    for i in range(n + 1):
        for j in range(n + 1):
            x, y = -half + j * step, -half + i * step
            vertices.append((x, y, 0.0))
            uvs.append(((x + half) / tile_m, (y + half) / tile_m))
    for i in range(n):
        for j in range(n):
            a = i * (n + 1) + j
            b, c = a + 1, a + n + 1
            indices += [a, b, c + 1, a, c + 1, c]
    return vertices, uvs, indices


def _floor_obj(vertices: list, uvs: list, indices: list) -> Path | None:
    """The floor mesh as an OBJ file in the user's cache, written once and shared by every
    process (named by its content). PyBullet keeps a mesh given as arrays for the life of the
    process (~160 kB per client created), but not one loaded from a file. None if the cache
    cannot be written."""
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices]
    lines += [f"vt {u!r} {v!r}" for u, v in uvs]
    lines.append("vn 0 0 1")
    for k in range(0, len(indices), 3):
        a, b, c = (i + 1 for i in indices[k : k + 3])
        lines.append(f"f {a}/{a}/1 {b}/{b}/1 {c}/{c}/1")
    text = "\n".join(lines) + "\n"
    folder = cache_dir()
    path = folder / f"floor-{hashlib.sha256(text.encode()).hexdigest()[:16]}.obj"
    if path.is_file():
        return path
    if not folder.parent.parent.is_dir():  # no home (HOME=/nonexistent): none is made for it
        return None
    try:
        folder.mkdir(parents=True, exist_ok=True)
        write_whole(path, lambda fh: fh.write(text.encode()))  # a render worker never reads half of it
    except OSError:
        return None
    return path


def build_world(world: WorldSpec, cid: int, collisions: bool = True) -> dict[str, int]:
    """Create the floor and landmarks; returns body ids by name ('floor' and each landmark)."""
    vertices, uvs, indices = _floor_mesh(world.floor.size_m, world.floor.texture_tile_m)
    obj = _floor_obj(vertices, uvs, indices)
    mesh = (
        {"fileName": str(obj)}
        if obj is not None
        else {"vertices": vertices, "indices": indices, "uvs": uvs, "normals": [(0.0, 0.0, 1.0)] * len(vertices)}
    )
    floor_vis = pb.createVisualShape(pb.GEOM_MESH, physicsClientId=cid, **mesh)
    floor_col = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=cid) if collisions else -1
    floor = pb.createMultiBody(0.0, floor_col, floor_vis, physicsClientId=cid)
    # PyBullet multiplies the restitutions of a contact's two bodies: the world's are 1, so a
    # vehicle's own (its parameter file's [contact]) is what an impact rebounds with
    pb.changeDynamics(floor, -1, lateralFriction=world.floor.friction, restitution=1.0, physicsClientId=cid)
    if world.floor.texture_path is not None:
        tex = pb.loadTexture(str(world.floor.texture_path), physicsClientId=cid)
        pb.changeVisualShape(floor, -1, textureUniqueId=tex, rgbaColor=(1, 1, 1, 1), physicsClientId=cid)
    ids = {"floor": floor}
    for lm in world.landmarks:
        sx, sy, sz = lm.size_m
        # each shape's geometry, and its size as the visual and the collision shape take it
        shapes: dict[Shape, tuple[int, dict[str, Any], dict[str, Any] | None]] = {
            Shape.BOX: (pb.GEOM_BOX, {"halfExtents": (sx / 2, sy / 2, sz / 2)}, None),
            Shape.CYLINDER: (pb.GEOM_CYLINDER, {"radius": sx, "length": sz}, {"radius": sx, "height": sz}),
            Shape.SPHERE: (pb.GEOM_SPHERE, {"radius": sx}, None),
        }
        geometry, seen, solid = shapes[lm.shape]
        vis = pb.createVisualShape(geometry, rgbaColor=lm.color_rgba, physicsClientId=cid, **seen)
        collide = collisions and lm.collision
        col = pb.createCollisionShape(geometry, physicsClientId=cid, **(solid or seen)) if collide else -1
        ids[lm.name] = pb.createMultiBody(0.0, col, vis, basePosition=lm.position_m, physicsClientId=cid)
        pb.changeDynamics(ids[lm.name], -1, restitution=1.0, physicsClientId=cid)
    return ids


def load_vehicle_body(
    vehicle: VehicleParams,
    cid: int,
    position: tuple[float, float, float],
    orientation: tuple[float, float, float, float],
    merged: bool = False,
) -> int:
    """The vehicle's URDF in the world, base_link at `position` and `orientation`.

    `merged`: as one rigid body (the flight world's): its fixed links (rotors, camera mounts)
    merged into base_link, so PyBullet steps one body instead of a tree of fixed joints (about
    half the cost of a step). PyBullet's merge gets the compound inertia wrong (the quad's roll
    and pitch inertia come out 8 % off, one too large and the other too small), so the
    inertia is set to the one VehicleParams computes from the URDF (its principal moments: the
    products of inertia of the shipped airframes are under 1e-3 of them). The merged body's
    inertial frame sits at the centre of mass: `inertial_offset` says where."""
    flags = pb.URDF_USE_INERTIA_FROM_FILE | (pb.URDF_MERGE_FIXED_LINKS if merged else 0)
    try:
        with c_output_silenced():  # the merge prints a line for each link it merges
            body = pb.loadURDF(str(vehicle.pybullet_urdf_path), position, orientation, flags=flags, physicsClientId=cid)
    except pb.error as exc:
        raise ConfigError(f"PyBullet could not load {vehicle.urdf_path}: {exc}") from None
    # PyBullet damps every link a little by default (0.04); the parameter file's drag is the
    # only drag the vehicle should feel. How it meets the world is the parameter file's [contact].
    contact = vehicle.contact
    for link in range(-1, pb.getNumJoints(body, physicsClientId=cid)):
        pb.changeDynamics(
            body,
            link,
            linearDamping=0.0,
            angularDamping=0.0,
            restitution=contact.restitution,
            lateralFriction=contact.lateral_friction,
            physicsClientId=cid,
        )
    if merged and pb.getNumJoints(body, physicsClientId=cid) == 0:
        inertia = vehicle.inertia_kgm2
        diagonal = (inertia[0][0], inertia[1][1], inertia[2][2])
        pb.changeDynamics(body, -1, mass=vehicle.mass_kg, localInertiaDiagonal=diagonal, physicsClientId=cid)
    return body


def inertial_offset(body: int, cid: int) -> tuple[float, float, float] | None:
    """Where PyBullet's pose of `body`'s base (its inertial frame) is, from base_link's origin,
    in base_link axes; None when that frame is also turned. PyBullet reports and sets a base's
    pose at its inertial frame; a URDF is placed, and the simulator reports, at base_link's origin."""
    info = pb.getDynamicsInfo(body, -1, physicsClientId=cid)
    x, y, z, _ = info[4]
    if max(abs(x), abs(y), abs(z)) > 1e-9:
        return None
    ox, oy, oz = info[3]
    return (ox, oy, oz)
