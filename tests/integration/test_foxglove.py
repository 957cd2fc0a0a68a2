"""The Foxglove bridge, from outside.

Its integration tests (several layers, in-process or one process started); the others are in tests/e2e/test_foxglove.py."""

from __future__ import annotations

import socket

from tests.e2e.test_foxglove import _quadsim


def test_a_port_in_use_is_one_line_and_exit_2() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        proc = _quadsim("run", "--script", "hover", "--no-record", "--foxglove", f"127.0.0.1:{port}")
        out, err = proc.communicate(timeout=60)
    assert proc.returncode == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"quadsim: error: --foxglove 127.0.0.1:{port}: cannot serve there")
    assert "in use" in lines[0]


def test_bad_endpoint_from_the_command_line_is_exit_2() -> None:
    proc = _quadsim("run", "--script", "hover", "--no-record", "--foxglove", "127.0.0.1:http")
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 2
    assert len(err.strip().splitlines()) == 1 and "--foxglove" in err and "Traceback" not in err


def test_loopback_serving_says_no_warning() -> None:
    proc = _quadsim("run", "--script", "hover", "--duration", "0.5", "--cameras", "none", "--no-record", "--foxglove")
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert "serving ws://127.0.0.1:8765" in out and "warning" not in out + err
