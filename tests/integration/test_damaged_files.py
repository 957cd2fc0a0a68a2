"""Damaged inputs to info, recover and the reader: a clear message, exit 2, no traceback."""

import os
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from quadsim import QuadsimError
from quadsim.recording.reader import RecordingReader
from tests.helpers import ROOT
from tests.helpers.cli import bare_env, run_main
from tests.helpers.recording import record_flight


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
    return run_main(*args, cwd=ROOT, env=bare_env())


EXPECTED = {
    "empty": "empty file",
    "random": "not an MCAP file",
    "truncated": "cut short",
    "not_mcap": "not an MCAP file",
    "magic_only": "no readable header",
    "other_topics": "not a quadsim recording",
}
#: files that are sound but not quadsim's: `info` describes them (exit 0), other commands refuse them
FOREIGN = {"other_topics"}


def test_info_describes_another_programs_sound_file(tmp_path, good):
    out = cli("info", _make("other_topics", tmp_path, good))
    assert out.returncode == 0 and not out.stderr, out.stderr
    note = next(line for line in out.stdout.splitlines() if line.startswith("note "))
    assert "not a quadsim recording (no /quad_cmd_twist, /quad/pose" in note and "replay shows what it has" in note


@pytest.mark.parametrize("kind", sorted(set(EXPECTED) - FOREIGN))
def test_info_on_damaged_input(kind, tmp_path, good):
    out = cli("info", _make(kind, tmp_path, good))
    assert out.returncode == 2 and "Traceback" not in out.stderr
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith("quadsim: error:") and EXPECTED[kind] in last


def test_info_on_truncated_file_says_how_much_is_readable(tmp_path, good):
    out = cli("info", _make("truncated", tmp_path, good))
    assert "Readable:" in out.stderr and "complete chunks" in out.stderr and "main.py recover" in out.stderr


def test_info_on_a_cut_short_file_says_the_error_alone(tmp_path, good):
    """Checked first, then printed: no half of a report before the error."""
    out = cli("info", _make("truncated", tmp_path, good))
    assert out.returncode == 2 and out.stdout == ""
    assert len(out.stderr.strip().splitlines()) == 1 and "cut short" in out.stderr


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


# --- check over a folder: every file reported, the worst outcome decides the exit code ---------


def _damaged_chunk(good: Path, dst: Path) -> Path:
    """`good` with a byte of its first chunk of states flipped (zstd refuses it). The file's first
    chunk holds only the latched scene messages (the "recording started" event's metadata record
    closes it): losing those still lets the flight re-fly."""
    from tests.helpers.damaged_corpus import OP_CHUNK, layout

    data = bytearray(good.read_bytes())
    chunk = layout(bytes(data)).of(OP_CHUNK)[1]
    data[chunk.start + chunk.length // 2] ^= 0x5A
    dst.write_bytes(bytes(data))
    return dst


@pytest.mark.parametrize("option", ["--tolerance-m", "--tolerance-rad"])
@pytest.mark.parametrize("value", ["-0.001", "nan", "-inf"])
def test_check_refuses_a_negative_or_nan_tolerance(option, value, good):
    out = cli("check", good, f"{option}={value}")
    assert out.returncode == 2 and "Traceback" not in out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and option in lines[0] and "error" in lines[0]
    assert out.stdout == ""  # refused before flying anything


# --- recover --------------------------------------------------------------------------------------


def test_recover_keeps_the_chunks_around_a_damaged_one(tmp_path, good):
    bad = _damaged_chunk(good, tmp_path / "bad.mcap")
    out = cli("recover", bad, "-o", tmp_path / "saved.mcap")
    assert out.returncode == 0, out.stderr
    assert "chunk at byte" in out.stdout and "are skipped" in out.stdout  # says what was lost: topics, span
    with open(good, "rb") as fh:
        everything = sum(1 for _ in make_reader(fh).iter_messages())
    with open(tmp_path / "saved.mcap", "rb") as fh:
        saved = [m.log_time for _, _, m in make_reader(fh, validate_crcs=True).iter_messages()]
    assert 0.5 * everything < len(saved) < everything and saved[-1] >= 3.9e9  # the chunks after it too
