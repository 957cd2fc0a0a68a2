"""Shared fixtures. Tests run headless: PyBullet DIRECT, SDL dummy drivers."""

import os

import pytest

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")


@pytest.fixture(scope="session")
def vehicle():
    from quadsim.vehicle.params import load_vehicle

    return load_vehicle()
