"""Damaged inputs to info, recover and the reader: a clear message, exit 2, no traceback."""

import os
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.writer import Writer

from quadsim import QuadsimError
from quadsim.recording.reader import RecordingReader
from tests.recording_helpers import record_flight

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    path = tmp_path_factory.mktemp("good") / "good.mcap"
    record_flight(path, cameras=False, script="z_mode height\n4.0 linear.z=0\n")
    return path


def _make(kind: str, folder: Path, good: Path) -> Path:
    path = folder / f"{kind}.mcap"
    if kind == "empty":
        path.write_bytes(b"")
    elif kind == "random":
        path.write_bytes(os.urandom(5000))
    elif kind == "truncated":
        data = good.read_bytes()
        path.write_bytes(data[: len(data) // 2])
    elif kind == "not_mcap":
        path = folder / "notes.txt"
        path.write_text("these are not the bytes you are looking for\n" * 20)
    elif kind == "magic_only":
        path.write_bytes(b"\x89MCAP0\r\n")
    elif kind == "other_topics":
        with open(path, "wb") as fh:
            w = Writer(fh)
            w.start(profile="", library="someone else")
            sid = w.register_schema("Blob", "jsonschema", b"{}")
            cid = w.register_channel("/weather", "json", sid)
            for i in range(10):
                w.add_message(cid, i * 1000, b'{"t": 20}', i * 1000)
            w.finish()
    return path


def cli(*args):
    return subprocess.run(
        [sys.executable, str(ROOT / "main.py"), *map(str, args)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT)},
    )


EXPECTED = {
    "empty": "empty file",
    "random": "not an MCAP file",
    "truncated": "cut short",
    "not_mcap": "not an MCAP file",
    "magic_only": "no readable header",
    "other_topics": "not a quadsim recording",
}


@pytest.mark.parametrize("kind", list(EXPECTED))
def test_info_on_damaged_input(kind, tmp_path, good):
    out = cli("info", _make(kind, tmp_path, good))
    assert out.returncode == 2 and "Traceback" not in out.stderr
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith("quadsim: error:") and EXPECTED[kind] in last


def test_info_on_truncated_file_says_how_much_is_readable(tmp_path, good):
    out = cli("info", _make("truncated", tmp_path, good))
    assert "Readable:" in out.stderr and "complete chunks" in out.stderr and "quadsim recover" in out.stderr


@pytest.mark.parametrize("kind", ["empty", "random", "not_mcap", "magic_only", "other_topics"])
def test_recover_refuses_what_it_cannot_use(kind, tmp_path, good):
    src = _make(kind, tmp_path, good)
    out = cli("recover", src)
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert len([line for line in out.stderr.splitlines() if line.strip()]) == 1
    assert not list(tmp_path.glob("*.recovered.mcap"))


def test_recover_will_not_overwrite(tmp_path, good):
    src = _make("truncated", tmp_path, good)
    target = tmp_path / "taken.mcap"
    target.write_bytes(b"precious")
    out = cli("recover", src, "-o", target)
    assert out.returncode == 2 and "already exists" in out.stderr and target.read_bytes() == b"precious"


@pytest.mark.parametrize("kind", list(EXPECTED))
def test_reader_refuses_damaged_input(kind, tmp_path, good):
    with pytest.raises(QuadsimError) as err:
        RecordingReader(_make(kind, tmp_path, good))
    assert EXPECTED[kind] in str(err.value)


def test_missing_file(tmp_path):
    out = cli("info", tmp_path / "nothing.mcap")
    assert out.returncode == 2 and "no such file" in out.stderr
