"""Helpers for tests that work below the simulator: a vehicle's body alone in a world."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from quadsim.physics.client import WorldClient
from quadsim.physics.pybullet_world import PhysicsWorld
from quadsim.physics.world_spec import load_world
from quadsim.vehicle.params import VehicleParams


@contextmanager
def body_alone(vehicle: VehicleParams, physics_hz: int = 240) -> Iterator[PhysicsWorld]:
    """`vehicle`'s body alone in the default world, which is closed at the end."""
    client = WorldClient(load_world(), physics_hz, vehicle.gravity_mps2)
    try:
        yield PhysicsWorld(vehicle, client)
    finally:
        client.close()
