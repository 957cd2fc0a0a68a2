"""Damaged inputs to info, recover and the reader: a clear message, exit 2, no traceback; a
fleet's recording with crafted run parameters refused in one line by every command.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_damaged_files.py."""

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

from quadsim.apps.cli import main
from tests.helpers import RECORDINGS, ROOT
from tests.helpers.cli import file_size_limit, without_caches
from tests.helpers.recording import copy_recording, record_flight
from tests.integration.test_damaged_files import (
    _damaged_chunk,
    _make,
    cli,
    good,  # noqa: F401 (a fixture)
)


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


# --- a fleet's recording with crafted run parameters ---------------------------------------------


def _with_parameters(src: Path, dst: Path, edit) -> Path:
    """Copy a recording with its run parameters edited (a crafted or damaged file)."""

    def parameters(name: str, data: dict[str, str]) -> dict[str, str]:
        if name == "quadsim":
            data["parameters"] = json.dumps(edit(json.loads(data["parameters"])))
        return data

    return copy_recording(src, dst, metadata=parameters)


def _set(params: dict, path: str, value) -> dict:
    where = params
    *parents, last = path.split(".")
    for key in parents:
        where = where[int(key)] if isinstance(where, list) else where[key]
    where[int(last) if isinstance(where, list) else last] = value
    return params


CRAFTED = {
    "too_many": (lambda p: {**p, "fleet": p["fleet"] * 40}, "parameters.fleet: expected a list of 1 to 100"),
    "traversing_name": (lambda p: _set(p, "fleet.1.name", "../../bravo"), "not a unique ROS name segment"),
    "not_an_object": (lambda p: _set(p, "fleet.2", "charlie"), "parameters.fleet[2]: expected an object"),
    "traversing_urdf": (
        lambda p: _set(p, "fleet.0.vehicle.urdf", "../../../etc/evil.urdf"),
        "attachment(s) evil.urdf missing",
    ),
    "no_such_vehicle": (lambda p: _set(p, "fleet.2.name", "zulu"), "has no /zulu/quad/pose states"),
    "fleet_left_out": (lambda p: {k: v for k, v in p.items() if k != "fleet"}, "parameters.fleet: expected a list"),
}


@pytest.mark.parametrize("case", list(CRAFTED))
def test_a_crafted_fleet_recording_is_refused_in_one_line_by_every_command(tmp_path, case):
    """Hostile parameters in a fleet's recording (the shipped fleet of three's): info and replay
    still show what is there, check and replay --resim refuse it in one line naming why, and
    nothing is written outside the folder asked for."""
    edit, why = CRAFTED[case]
    path = _with_parameters(RECORDINGS / "fleet_trio_wind.mcap", tmp_path / f"{case}.mcap", edit)
    before = set(Path("/etc").iterdir())
    out = cli("check", str(path))
    assert out.returncode == 2 and "Traceback" not in out.stderr, out.stdout + out.stderr
    assert f"ERROR {path}:" in out.stdout and why in out.stdout, out.stdout
    resim = cli("replay", str(path), "--resim", "--out", str(tmp_path / "resim"))
    assert resim.returncode == 2 and "Traceback" not in resim.stderr and why in resim.stderr, resim.stderr
    assert len(resim.stderr.strip().splitlines()) == 1, resim.stderr
    for argv in (("info", str(path)), ("replay", str(path), "--headless")):
        shown = cli(*argv)
        assert shown.returncode == 0 and "Traceback" not in shown.stderr, (argv, shown.stderr)
    assert set(Path("/etc").iterdir()) == before and not (tmp_path / "resim").exists()


@pytest.mark.parametrize("command", ["plot", "layout", "examples"])
def test_a_file_the_disk_refuses_is_one_line_leaves_nothing_and_the_retry_works(tmp_path, command):
    """On a full disk, --plot, layout and examples --copy said so but left a 0-byte file (or a
    half of the examples), and the retry was then refused as 'already exists'."""
    flight = str(ROOT / "tests" / "recordings" / "climb_cascade.mcap")
    out = tmp_path / "out"
    out.mkdir()
    args = {
        "plot": ["replay", flight, "--headless", "--plot", str(out / "p.png")],
        "layout": ["layout", flight, "-o", str(out / "l.json")],
        "examples": ["examples", "--copy", str(out / "ex")],
    }[command]
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), "SDL_VIDEODRIVER": "dummy", **without_caches(tmp_path)}

    def run(limit=None) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, str(ROOT / "main.py"), *args], capture_output=True, text=True, env=env, preexec_fn=limit
        )

    refused = run(file_size_limit(1024))
    assert refused.returncode == 2 and "Traceback" not in refused.stderr, refused.stderr
    (line,) = [s for s in refused.stderr.splitlines() if "pybullet build time" not in s]
    assert "File too large; nothing was" in line, line
    assert [p for p in out.rglob("*") if p.is_file()] == []  # no cut file, no hidden partial one
    retried = run()
    assert retried.returncode == 0, retried.stderr
    assert [p for p in out.rglob("*") if p.is_file()] and all(p.stat().st_size for p in out.rglob("*") if p.is_file())
    again = run()  # and what is there is never overwritten
    assert again.returncode == 2 and "exists" in again.stderr, again.stderr
