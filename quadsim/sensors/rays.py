"""Ray casts from a vehicle into its world: one batched PyBullet call, the vehicle's own body unseen.

The range finder and the LiDAR cast through here. A ray that meets its own vehicle's body on the way
out (a rotor's disc under a LiDAR's lower beams) is cast again, in a second batch of those rays
alone, from where it leaves the vehicle's reach (the sphere about base_link that holds the body in
any attitude, PhysicsWorld.reach_m): Bullet's ray test reports a ray that starts inside a cylinder
as hitting it at once, so a ray cannot simply go on from inside the part it met. Something else
inside that sphere is unseen by those rays alone (it would be touching the vehicle). Every vehicle
is posed first (quadsim.physics.client.WorldClient.posed): a vehicle that quadsim stepped itself
is where it flew to, for this vehicle's rays and for the others'.
"""

from __future__ import annotations

import math

import numpy as np

from quadsim.core.kinematics import Vec3
from quadsim.physics.client import WorldClient
from quadsim.physics.pybullet_quiet import pb


def cast(
    scene: WorldClient,
    own_body: int,
    origin: np.ndarray,
    directions: np.ndarray,
    max_range_m: float,
    reach: tuple[Vec3, float],
) -> np.ndarray:
    """The distance along each ray (rows of `directions`, unit vectors in `world`) from `origin` to
    the first thing that is not body `own_body`, up to `max_range_m`; inf where there is none.
    `reach`: the centre (base_link's origin, `world`) and radius of the sphere holding that body."""
    cid = scene.posed()
    ends = origin + directions * max_range_m
    distances, hit = _batch(cid, np.broadcast_to(origin, ends.shape), ends, max_range_m)
    own = np.flatnonzero(hit == own_body)
    if len(own):
        distances[own] = math.inf
        out_m = _leaving(origin, directions[own], reach)
        going = out_m < max_range_m
        own, out_m = own[going], out_m[going]
        if len(own):
            again, hit_again = _batch(cid, origin + directions[own] * out_m[:, None], ends[own], max_range_m - out_m)
            distances[own] = np.where(hit_again == own_body, math.inf, out_m + again)
    return distances


def cast_one(
    scene: WorldClient,
    own_body: int,
    origin: Vec3,
    direction: Vec3,
    max_range_m: float,
    reach: tuple[Vec3, float],
) -> float:
    """`cast` for one ray, in plain Python (a range finder's reading: a numpy array of one
    costs ten times its rayTest): the distance to the first thing that is not `own_body`."""
    ox, oy, oz = origin
    dx, dy, dz = direction
    end = (ox + dx * max_range_m, oy + dy * max_range_m, oz + dz * max_range_m)
    body, _, fraction, _, _ = pb.rayTest(origin, end, physicsClientId=scene.posed())[0]
    if body == own_body:  # seldom: the beam starts inside a part that is not a box
        return float(cast(scene, own_body, np.array(origin), np.array([direction]), max_range_m, reach)[0])
    return fraction * max_range_m if body >= 0 else math.inf


def _leaving(origin: np.ndarray, directions: np.ndarray, reach: tuple[Vec3, float]) -> np.ndarray:
    """How far along each ray from `origin` it leaves the sphere `reach` (centre, radius), 0 where
    it is outside it from the start."""
    centre, radius = reach
    offset = origin - np.asarray(centre, dtype=float)
    # written out, not `@`: OpenBLAS's sums differ in the last bit from one CPU to another
    b = directions[:, 0] * offset[0] + directions[:, 1] * offset[1] + directions[:, 2] * offset[2]
    c = float(offset[0] * offset[0] + offset[1] * offset[1] + offset[2] * offset[2]) - radius * radius
    return np.maximum(-b + np.sqrt(np.maximum(b * b - c, 0.0)), 0.0)


def _batch(
    cid: int, starts: np.ndarray, ends: np.ndarray, length_m: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """One rayTestBatch: each ray's distance from its start (inf: no hit) and the body it hit (-1: none)."""
    # arrays go in as they are: PyBullet reads them as sequences, twice as fast as lists made of them
    results = pb.rayTestBatch(np.ascontiguousarray(starts), ends, physicsClientId=cid)
    hit = np.fromiter((r[0] for r in results), dtype=np.int64, count=len(results))
    fraction = np.fromiter((r[2] for r in results), dtype=float, count=len(results))
    distances = np.where(hit >= 0, fraction * length_m, math.inf)
    return distances, hit
