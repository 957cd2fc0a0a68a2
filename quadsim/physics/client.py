"""The PyBullet client a simulation runs in: gravity, the step length and the world's scenery
(floor and landmarks), built once and shared by every vehicle flying in it (one vehicle, or a
fleet). Stepping it advances every body at once."""

from __future__ import annotations

import os
import weakref
from typing import Any

from quadsim.core.kinematics import Vec3
from quadsim.errors import QuadsimError
from quadsim.physics.pybullet_quiet import pb
from quadsim.physics.scene import build_world
from quadsim.physics.world_spec import WorldSpec


class WorldClient:
    """A PyBullet client holding the world; vehicles add their bodies to it (PhysicsWorld)."""

    def __init__(self, world: WorldSpec, physics_hz: int, gravity_mps2: float, gui: bool = False) -> None:
        if gui and not os.environ.get("DISPLAY") and os.name != "nt":
            raise QuadsimError(
                "PyBullet's window (gui=True) needs a display (DISPLAY is not set); run without it",
                "--gui needs a display (DISPLAY is not set); run without --gui",
            )
        self.world = world
        self.dt_s = 1.0 / physics_hz
        self.gravity_mps2 = gravity_mps2
        self.gui = gui
        self.cid = pb.connect(pb.GUI if gui else pb.DIRECT)
        if self.cid < 0:
            raise QuadsimError("could not start PyBullet" + (" with a GUI" if gui else ""))
        #: disconnects the client when this is closed, or forgotten unclosed (an env never closed)
        self._disconnect = weakref.finalize(self, _disconnect, self.cid)
        cid = self.cid
        pb.setGravity(0.0, 0.0, -gravity_mps2, physicsClientId=cid)
        pb.setTimeStep(self.dt_s, physicsClientId=cid)
        pb.setPhysicsEngineParameter(deterministicOverlappingPairs=1, physicsClientId=cid)
        if gui:
            pb.configureDebugVisualizer(pb.COV_ENABLE_GUI, 0, physicsClientId=cid)
        #: body ids of the scenery by name ('floor' and each landmark)
        self.landmark_ids = build_world(world, cid)
        #: what each body is called in contacts: the scenery's names, then each vehicle's
        self.body_names = {body: name for name, body in self.landmark_ids.items()}
        #: the scenery as geometry: the heights of its level planes (the floor) and each landmark's
        #: box by name (a landmark without collision is left out: nothing touches it); None when a
        #: plane is tilted (no vehicle then skips its contact query)
        self.scenery = self._scenery_geometry()
        #: the world's contacts after the last step by body, asked when first wanted (touching)
        self._touching: dict[int, tuple[tuple[int, float], ...]] | None = None
        #: the vehicles flying in this world (quadsim.physics.pybullet_world.PhysicsWorld)
        self.bodies: list[Any] = []
        #: the vehicles near another one this step, measured once for all at the first asking
        self.near_others: set[Any] | None = None
        #: where each vehicle was when every pair was last measured, and half its slack then
        #: (quadsim.physics.pybullet_world._near_others)
        self.apart: dict[Any, tuple[Vec3, float]] = {}

    def posed(self) -> int:
        """The client, once every vehicle in it is where it flew to: a vehicle clear of
        everything is stepped by quadsim itself, and PyBullet's copy of it is posed only when
        something reads the scene (cameras, a caller's own PyBullet queries). Call it before
        reading the scene from PyBullet."""
        for body in self.bodies:
            if body._stale:
                body._pose_pybullet()
        return self.cid

    def _scenery_geometry(self) -> tuple[tuple[float, ...], dict[str, tuple[Vec3, Vec3]]] | None:
        cid = self.cid
        planes: list[float] = []
        boxes: dict[str, tuple[Vec3, Vec3]] = {}
        for name, body in self.landmark_ids.items():
            shapes = pb.getCollisionShapeData(body, -1, physicsClientId=cid)
            if not shapes:
                continue
            if shapes[0][2] == pb.GEOM_PLANE:
                position, orientation = pb.getBasePositionAndOrientation(body, physicsClientId=cid)
                level = tuple(shapes[0][5]) == (0.0, 0.0, 0.0) and tuple(shapes[0][6]) == (0.0, 0.0, 0.0, 1.0)
                if not (
                    level and tuple(orientation) == (0.0, 0.0, 0.0, 1.0) and tuple(shapes[0][3]) == (0.0, 0.0, 1.0)
                ):
                    return None
                planes.append(position[2])
            else:
                lo, hi = pb.getAABB(body, -1, physicsClientId=cid)
                boxes[name] = (tuple(lo), tuple(hi))
        return tuple(planes), boxes

    def step(self) -> None:
        """One physics step of every body in the world (a vehicle that quadsim stepped itself this
        step is posed where it was first: PyBullet's step then moves only a copy of it, far from
        anything it could touch)."""
        pb.stepSimulation(self.posed())
        self._touching = None

    def touching(self, body: int) -> tuple[tuple[int, float], ...]:
        """What `body` touched in the last step: (other body, world z of the contact normal
        pointing at `body`) for each contact point, as `getContactPoints(body)` gives them. The
        world's contacts are asked once a step, for every vehicle in it (a fleet asked once per
        vehicle, about a tenth of a vehicle's step each), and kept until the next step, whoever
        is moved by hand in between: a collision is the same contact for both vehicles."""
        if self._touching is None:
            table: dict[int, list[tuple[int, float]]] = {}
            for point in pb.getContactPoints(physicsClientId=self.cid):
                a, b, nz = point[1], point[2], point[7][2]  # the normal on b points at a
                table.setdefault(a, []).append((b, nz))
                table.setdefault(b, []).append((a, -nz))
            self._touching = {body: tuple(points) for body, points in table.items()}
        return self._touching.get(body, ())

    def close(self) -> None:
        self._disconnect()  # once: the first call disconnects, later ones do nothing
        self.cid = -1


def _disconnect(cid: int) -> None:
    try:
        pb.disconnect(physicsClientId=cid)
    except pb.error:
        pass
