"""Ray casts from a vehicle into its world: one batched PyBullet call, the vehicle's own body unseen.

The range finder and the LiDAR cast through here. A ray that leaves its vehicle's body from inside
does not hit it (Bullet's ray test skips a convex shape it starts in); one that meets a part of its
own body on the way out (a rotor's disc under a LiDAR's downward beam) is cast again from just past
that point, at most `MAX_OWN_PASSES` times, so the distances are those to the first thing that is
not the vehicle. Every vehicle is posed first (quadsim.physics.client.WorldClient.posed): a vehicle
that quadsim stepped itself is where it flew to, for this vehicle's rays and for the others'.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from quadsim.physics.client import WorldClient
from quadsim.physics.pybullet_quiet import pb

#: how many times a ray that met its own vehicle is cast again from past that point
MAX_OWN_PASSES = 3
#: how far past a hit on its own body a ray starts again, m
_PAST_M = 1e-4


def cast(
    scene: WorldClient, own_body: int, origin: np.ndarray, directions: np.ndarray, max_range_m: float
) -> np.ndarray:
    """The distance along each ray (rows of `directions`, unit vectors in `world`) from `origin` to
    the first thing that is not body `own_body`, up to `max_range_m`; inf where there is none."""
    cid = scene.posed()
    ends = origin + directions * max_range_m
    distances, hit = _batch(cid, np.broadcast_to(origin, ends.shape), ends, max_range_m)
    start = np.zeros(len(directions))
    for _ in range(MAX_OWN_PASSES):
        own = np.flatnonzero(hit == own_body)
        if not len(own):
            break
        start[own] = distances[own] + _PAST_M
        left = start[own] < max_range_m
        own, from_m = own[left], start[own][left]
        distances[hit == own_body] = math.inf
        hit[hit == own_body] = -1
        if not len(own):
            break
        again, hit_again = _batch(cid, origin + directions[own] * from_m[:, None], ends[own], max_range_m - from_m)
        distances[own] = from_m + again
        hit[own] = hit_again
    distances[hit == own_body] = math.inf  # still its own body after every pass
    return distances


def _batch(cid: int, starts: np.ndarray, ends: np.ndarray, length_m: Any) -> tuple[np.ndarray, np.ndarray]:
    """One rayTestBatch: each ray's distance from its start (inf: no hit) and the body it hit (-1: none)."""
    # arrays go in as they are: PyBullet reads them as sequences, twice as fast as lists made of them
    results = pb.rayTestBatch(np.ascontiguousarray(starts), ends, physicsClientId=cid)
    hit = np.fromiter((r[0] for r in results), dtype=np.int64, count=len(results))
    fraction = np.fromiter((r[2] for r in results), dtype=float, count=len(results))
    distances = np.where(hit >= 0, fraction * length_m, math.inf)
    return distances, hit
