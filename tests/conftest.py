"""Shared fixtures. Tests run headless: PyBullet DIRECT, SDL dummy drivers. A recording made
without --out (in this process or a command it starts) lands in a temporary folder, removed at the
end, never in the checkout's recordings/ or the user's $QUADSIM_RECORDINGS (a test once left a
file there on every run); tests of where recordings land by default unset it themselves."""

import atexit
import os
import shutil
import tempfile

import pytest

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
_RECORDINGS = tempfile.mkdtemp(prefix="quadsim-test-recordings-")
os.environ["QUADSIM_RECORDINGS"] = _RECORDINGS
atexit.register(shutil.rmtree, _RECORDINGS, ignore_errors=True)


@pytest.fixture(scope="session")
def vehicle():
    from quadsim.vehicle.params import load_vehicle

    return load_vehicle()
