"""Nothing is lost: recordings survive Ctrl-C, SIGTERM, SIGKILL, exceptions and a full disk."""

import errno
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader

from quadsim import QuadsimError, SimConfig, Simulator, Twist, ZMode
from quadsim.recording.fanout import TopicFanout
from quadsim.recording.mcap_scan import McapFile
from quadsim.recording.writer import McapRecorder, check_writable
from quadsim.session.outputs import OutputOptions, RecordedRun
from tests.helpers import ROOT
from tests.helpers.cli import run_main
from tests.helpers.recording import record_flight


def _summary_ok(path: Path) -> dict:
    with open(path, "rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None and summary.statistics is not None
    return {summary.channels[c].topic: n for c, n in summary.statistics.channel_message_counts.items()}


class FillingDisk:
    """A file that fails with ENOSPC once `limit` bytes have been written."""

    def __init__(self, path: Path, limit: int):
        self._fh = open(path, "wb")
        self._limit = limit
        self.written = 0

    def write(self, data) -> int:
        if self.written + len(data) > self._limit:
            raise OSError(errno.ENOSPC, "No space left on device")
        self.written += len(data)
        return self._fh.write(data)

    def flush(self):
        self._fh.flush()

    def seek(self, offset, whence=0):
        return self._fh.seek(offset, whence)

    def tell(self):
        return self._fh.tell()

    def close(self):
        self._fh.close()


def test_disk_full_stops_recording_keeps_flying_keeps_data(tmp_path):
    path = tmp_path / "full.mcap"
    disk = FillingDisk(path, limit=60_000)
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT)) as sim:
        rec = McapRecorder(path, sim.description(), stream=disk)
        fanout = TopicFanout(sim.config.rates.physics_hz)
        sim.add_sink(fanout.add_vehicle())
        fanout.add_consumer(rec)
        sim.send(Twist(linear_x=-0.5))  # backwards: the way ahead has a tower in it
        sim.run_for(30.0)  # the recording fills up long before the end
        assert rec.error is not None and "No space left" in rec.error and "quadsim recover" in rec.error
        assert sim.state.position_m[0] < -13.0  # still flew all the way
        rec.close()
    disk.close()
    with McapFile(path) as found:
        assert found.message_count and 0 < found.span_ns[1] < 30e9  # what was written before is readable


def test_refuses_to_start_where_it_cannot_write(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    with pytest.raises(QuadsimError, match="cannot create the recording folder"):
        check_writable(blocker / "sub" / "run.mcap")
    with pytest.raises(QuadsimError, match="MB free"):
        check_writable(tmp_path / "run.mcap", min_free_bytes=1 << 62)
    existing = tmp_path / "exists.mcap"
    existing.write_bytes(b"keep me")
    with pytest.raises(QuadsimError, match="already exists"):
        check_writable(existing)
    assert existing.read_bytes() == b"keep me"


def _run_hover(out: Path) -> subprocess.CompletedProcess:
    """`run --script hover` recorded to `out`, without cameras."""
    return run_main("run", "--script", "hover", "--cameras", "none", "--out", out, cwd=ROOT)


def test_a_recording_that_cannot_start_says_what_to_do_in_the_callers_terms(tmp_path):
    """From Python, the advice names record()'s out=; from the command line, its flags (a
    Python caller has no --out to choose)."""
    from quadsim import record

    existing = tmp_path / "exists.mcap"
    existing.write_bytes(b"keep me")
    with Simulator(SimConfig()) as sim, pytest.raises(QuadsimError) as raised:
        record(sim, existing)
    assert "already exists; record to another file or folder (out=" in str(raised.value)
    assert "--" not in str(raised.value)
    assert raised.value.cli_message == f"{existing} already exists; choose another --out (nothing is overwritten)"
    assert existing.read_bytes() == b"keep me"
    out = _run_hover(existing)
    assert out.returncode == 2 and out.stderr == f"quadsim: error: {raised.value.cli_message}\n"
    with pytest.raises(QuadsimError) as raised:
        check_writable(tmp_path / "run.mcap", min_free_bytes=1 << 62)
    assert str(raised.value).endswith("(free some space, or record elsewhere: out=DIR)")
    assert raised.value.cli_message.endswith("(free some space, use --out elsewhere, or --no-record)")


def test_cli_refuses_unwritable_out_with_exit_2(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    out = _run_hover(blocker / "dir")
    assert out.returncode == 2 and "Traceback" not in out.stderr and "recording folder" in out.stderr


def test_exception_in_the_loop_still_finishes_the_file(tmp_path):
    class Boom:
        def on_command(self, step, twist):
            pass

        def on_state(self, state):
            if state.step >= 480:
                raise RuntimeError("a bug in some sink")

    path = tmp_path / "boom.mcap"
    with pytest.raises(RuntimeError, match="a bug"), Simulator(SimConfig()) as sim:
        with RecordedRun(sim, OutputOptions(out=path, cameras=()), "boom"):
            sim.add_sink(Boom())
            sim.send(Twist(linear_z=0.5))
            sim.run_for(5.0)
    counts = _summary_ok(path)  # finished properly: summary and index present
    assert counts["/quad/pose"] >= 119


def test_two_recorded_runs_give_identical_messages(tmp_path):
    def messages(path):
        with open(path, "rb") as fh:
            return [(ch.topic, m.log_time, m.data) for _, ch, m in make_reader(fh).iter_messages(log_time_order=False)]

    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    record_flight(a, workers=2)
    record_flight(b, workers=2)
    ma, mb = messages(a), messages(b)
    assert len(ma) > 1000 and any(t.endswith("compressed") for t, _, _ in ma)
    assert ma == mb  # images included, and in the same order


@pytest.mark.skipif(sys.platform == "win32", reason="file size limits are POSIX")
def test_a_write_error_on_the_file_itself_stops_recording_not_the_flight(tmp_path):
    """The recorder's own file (not a stream it was given): the OS refuses to let it grow."""
    import resource

    out = tmp_path / "capped.mcap"

    def cap_file_size():  # Python ignores SIGXFSZ: an over-long write fails with EFBIG
        resource.setrlimit(resource.RLIMIT_FSIZE, (60_000, 60_000))

    result = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "run", "--script", "square", "--cameras", "none", "--out", str(out)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        preexec_fn=cap_file_size,
    )
    # the flight went on, but a run whose recording stopped does not say "all fine": exit 1
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert "its recording did not" in result.stderr
    assert "recording stopped at sim time" in result.stdout and "main.py recover" in result.stdout
    # the reason: the OS's (File too large) when our flush meets it, the MCAP writer's own I/O error
    # when it meets it closing a chunk (a flight event's metadata record closes one)
    assert "File too large" in result.stdout or "I/O error from writing" in result.stdout
    assert "final pose" in result.stdout  # the flight went on to the end
    assert "WARNING" not in result.stderr  # one clear message, no noise from the writer
    with McapFile(out) as found:
        assert found.message_count and 0 < found.span_ns[1] < 30e9


@pytest.mark.skipif(sys.platform == "win32", reason="file size limits are POSIX")
@pytest.mark.parametrize("limit", [300_000, 1_000_000])
def test_a_full_disk_under_camera_frames_is_one_message_not_hundreds(tmp_path, limit):
    """With camera frames, the MCAP writer meets the full file while it takes a message, and
    foxglove-sdk reported every message after that on stderr (43 and 222 lines with these
    limits) before quadsim's one message; those records are now kept off the screen."""
    import resource

    def cap_file_size():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    run = ["run", "--script", "square", "--duration", "6", "--camera-size", "320x240"]
    result = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), *run, "--out", str(tmp_path / "capped.mcap")],
        capture_output=True,
        text=True,
        cwd=ROOT,
        preexec_fn=cap_file_size,
    )
    assert result.returncode == 1
    notes = ("sim time:", "quadsim: starting ")  # progress, and what is being started
    problems = [line for line in result.stderr.splitlines() if not line.startswith(notes)]
    assert len(problems) == 2, result.stderr  # recording stopped (with why); the run's closing line
    assert "recording stopped at sim time" in problems[0] and "main.py recover" in problems[0]
    assert "its recording did not" in problems[1]
