"""Damaged inputs to info, recover and the reader: a clear message, exit 2, no traceback."""

import contextlib
import errno
import io
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from quadsim import QuadsimError
from quadsim.apps.cli import main
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


@pytest.mark.parametrize("argv", [["--headless"], ["--plot", "p.png"], []])
def test_replay_refuses_a_cut_short_file_as_info_does(tmp_path, good, argv):
    """A run killed mid-write lost its last states: replay says what info says (what is
    readable, the recover command), in one line, exit 2, and plays nothing."""
    cut = _make("truncated", tmp_path, good)
    said = cli("info", cut).stderr
    out = cli("replay", cut, *argv)
    assert out.returncode == 2 and out.stdout == "" and out.stderr == said, out.stdout + out.stderr
    assert "Readable:" in said and " recover " in said
    assert not (ROOT / "p.png").exists()


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


def _changed_gains(good: Path, dst: Path) -> Path:
    """`good` as if flown with another position gain: re-flying it gives another flight."""
    from tests.helpers.damaged_corpus import build, read_content

    content = read_content(good)
    md = content.metadata("quadsim")
    entries = dict(md.metadata)
    params = json.loads(entries["parameters"])
    params["controller"]["gains"]["altitude_p_per_s"] *= 1.5
    entries["parameters"] = json.dumps(params)
    md.metadata = list(entries.items())
    dst.write_bytes(build(content))
    return dst


def test_check_folder_reports_every_file_and_exits_with_the_worst(tmp_path, good):
    folder = tmp_path / "runs"
    folder.mkdir()
    shutil.copy(good, folder / "a_good.mcap")
    _damaged_chunk(good, folder / "b_damaged.mcap")  # in the middle: the files after it are still checked
    _changed_gains(good, folder / "c_changed.mcap")
    empty = tmp_path / "d_empty"
    empty.mkdir()
    out = cli("check", folder, empty)
    assert out.returncode == 2 and "Traceback" not in out.stderr, out.stdout + out.stderr
    lines = out.stdout.splitlines()
    assert any(line.startswith("ok") and "a_good.mcap" in line for line in lines)
    assert any(line.startswith("ERROR") and "b_damaged.mcap" in line and "chunk at byte" in line for line in lines)
    assert any(line.startswith("FAIL") and "c_changed.mcap" in line for line in lines)
    assert any(line.startswith("ERROR") and "d_empty" in line for line in lines)
    assert lines[-1].startswith("1 of 3 recordings re-fly") and lines[-1].endswith(
        "; 1 changed; 1 unusable; 1 folder with no recording"
    )

    (folder / "b_damaged.mcap").unlink()
    assert cli("check", folder).returncode == 1  # none unusable, one changed
    (folder / "c_changed.mcap").unlink()
    assert cli("check", folder).returncode == 0


@pytest.mark.parametrize("option", ["--tolerance-m", "--tolerance-rad"])
@pytest.mark.parametrize("value", ["-0.001", "nan", "-inf"])
def test_check_refuses_a_negative_or_nan_tolerance(option, value, good):
    out = cli("check", good, f"{option}={value}")
    assert out.returncode == 2 and "Traceback" not in out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and option in lines[0] and "error" in lines[0]
    assert out.stdout == ""  # refused before flying anything


def test_a_damaged_chunk_of_camera_images_alone_is_skipped_and_check_goes_on(tmp_path):
    """Where a damaged chunk held only images (its index says so), the commands and states are
    whole: replay and check go on, and say what was skipped."""
    from tests.helpers.damaged_corpus import OP_CHUNK, RMessage, build, layout, read_content

    src = tmp_path / "cams.mcap"
    record_flight(src, size=(64, 48), script="z_mode height\n1.5 linear.z=0\n")
    content = read_content(src)
    images = {i.id for i in content.items if getattr(i, "topic", "").endswith("/image_raw/compressed")}
    is_image = [isinstance(i, RMessage) and i.channel_id in images for i in content.items]
    content.items = [i for i, img in zip(content.items, is_image) if not img] + [
        i for i, img in zip(content.items, is_image) if img
    ]  # the images last: the last chunks hold nothing else
    data = bytearray(build(content, chunk_messages=30))
    last = layout(bytes(data)).of(OP_CHUNK)[-2]
    data[last.start + last.length - 10] ^= 0x21
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))

    out = cli("replay", "--headless", bad)
    assert out.returncode == 0 and "Traceback" not in out.stderr
    assert (
        "quadsim: warning:" in out.stderr and "image_raw/compressed" in out.stderr and " s, are skipped" in out.stderr
    )
    frames = [int(line.split()[-2]) for line in out.stdout.splitlines() if line.startswith("camera")]
    assert frames and min(frames) < 45  # some frames are gone, the rest play
    out = cli("check", bad)
    assert out.returncode == 0, out.stdout + out.stderr
    assert out.stdout.startswith("ok") and "note: the chunk at byte" in out.stdout


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


class _Filling:
    """A file that fails with ENOSPC once `limit` bytes have been written to it."""

    def __init__(self, fh, limit: int) -> None:
        self._fh, self._left = fh, limit

    def write(self, data) -> int:
        self._left -= len(data)
        if self._left < 0:
            raise OSError(errno.ENOSPC, "No space left on device")
        return self._fh.write(data)

    def __getattr__(self, name):
        return getattr(self._fh, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self._fh.close()


@contextlib.contextmanager
def _small_disk(folder: Path, size_kib: int):
    """A tmpfs of `size_kib` at `folder` (root only); None where mounting is not allowed."""
    folder.mkdir()
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size_kib}k", "tmpfs", str(folder)], capture_output=True
    )
    try:
        yield folder if mounted.returncode == 0 else None
    finally:
        if mounted.returncode == 0:
            subprocess.run(["umount", str(folder)], check=True)


def test_recover_onto_a_full_disk_says_so_and_leaves_nothing(tmp_path, good, monkeypatch):
    src = _damaged_chunk(good, tmp_path / "bad.mcap")
    with _small_disk(tmp_path / "disk", 16) as disk:
        if disk is None:  # no tmpfs here: the disk fills up after 16 kB all the same
            disk = tmp_path / "disk"
            real_fdopen = os.fdopen
            monkeypatch.setattr(os, "fdopen", lambda fd, *a, **kw: _Filling(real_fdopen(fd, *a, **kw), 16 * 1024))
        out = io.StringIO()
        with contextlib.redirect_stderr(out), contextlib.redirect_stdout(io.StringIO()):
            code = main(["recover", str(src), "-o", str(disk / "saved.mcap")])
        assert code == 2
        assert out.getvalue().strip().splitlines() == [
            f"quadsim: error: cannot write {disk / 'saved.mcap'}: No space left on device; nothing was written"
        ]
        assert list(disk.iterdir()) == []  # no partial file, no temporary file


@pytest.mark.parametrize(("kept_bytes", "recoverable"), [(6000, False), (20000, True)])
def test_check_names_recover_only_where_recover_saves_something(tmp_path, kept_bytes, recoverable):
    """A recording cut short: check's refusal named `recover` even where not one message could be
    read, and recover then said there was nothing to recover."""
    cut = tmp_path / "cut.mcap"
    cut.write_bytes((ROOT / "tests" / "recordings" / "climb_cascade.mcap").read_bytes()[:kept_bytes])

    def cli(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, str(ROOT / "main.py"), *args], capture_output=True, text=True)

    checked, recovered = cli("check", str(cut)), cli("recover", str(cut))
    assert checked.returncode == 2 and "cut short" in checked.stdout
    assert ("main.py recover" in checked.stdout) == recoverable, checked.stdout
    assert ("nothing to recover" in checked.stdout) != recoverable, checked.stdout
    assert recovered.returncode == (0 if recoverable else 2), recovered.stderr
