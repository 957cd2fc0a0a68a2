"""The peers' bench stays optional: a missing peer is one line, the timing loop counts resets, and a
failing child is reported, not raised past the bench. Nothing here installs or runs a peer.

Its integration tests (several layers, in-process or one process started); the others are in tests/unit/test_bench_peers.py."""

from __future__ import annotations

import importlib.util
import sys

import pytest

from quadsim.apps.bench.peers import PYFLYT, measure_peer


@pytest.mark.skipif(importlib.util.find_spec("PyFlyt") is not None, reason="PyFlyt is installed here")
def test_a_failing_child_says_why() -> None:
    # this interpreter has no PyFlyt: the child fails on the import and the error names it
    with pytest.raises(RuntimeError, match=r"PyFlyt measurement failed .*ModuleNotFoundError"):
        measure_peer(PYFLYT, sys.executable, 30, steps=1)
