"""Nothing is lost: recordings survive Ctrl-C, SIGTERM, SIGKILL, exceptions and a full disk.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_recording_safety.py."""

import re
import signal
import subprocess
import sys
from pathlib import Path

from mcap.reader import make_reader

from quadsim.recording.mcap_scan import McapFile
from tests.helpers import ROOT
from tests.integration.test_recording_safety import _summary_ok


def _start_recording(tmp_path: Path) -> tuple[subprocess.Popen, Path]:
    """A real-time recorded run of 8 s, once it says it records."""
    out = tmp_path / "killed.mcap"
    command = ["run", "--script", "hover", "--duration", "8", "--realtime", "--cameras", "none", "--out", str(out)]
    proc = subprocess.Popen(
        [sys.executable, str(ROOT / "main.py"), *command],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith("recording to"):
            return proc, out
    proc.kill()
    raise AssertionError("the recording process did not start: " + proc.stderr.read())


def _flown_to(proc: subprocess.Popen, sim_s: float) -> None:
    """Wait until the run's progress says it has flown `sim_s` of its 8 s (it reports every 2 s)."""
    assert proc.stderr is not None
    for line in proc.stderr:
        if line.startswith("sim time:") and float(line.split("(")[1].split("/")[0]) >= sim_s:
            return
    raise AssertionError(f"the run ended before {sim_s} s of simulated time")


def test_sigkill_mid_run_recovers_all_but_the_last_second(tmp_path):
    proc, out = _start_recording(tmp_path)
    _flown_to(proc, 4.0)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    with McapFile(out) as found:
        assert not found.complete  # cut short, as a crash leaves it: no footer
    result = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "recover", str(out)], capture_output=True, text=True, cwd=ROOT
    )
    assert result.returncode == 0, result.stderr
    recovered = out.with_name("killed.recovered.mcap")
    counts = _summary_ok(recovered)
    with open(recovered, "rb") as fh:
        poses = [m.log_time for _, ch, m in make_reader(fh).iter_messages(topics=["/quad/pose"])]
    end_s = poses[-1] / 1e9
    # it had flown at least 4 s when killed: everything up to the last second is there
    assert end_s >= 4.0 - 1.0, end_s
    assert poses == [i * 4 * 1_000_000_000 // 240 for i in range(1, len(poses) + 1)]  # every state, no gaps
    assert counts["/quad_cmd_twist"] > 0 and counts["/tf_static"] == 1
    assert re.search(r"recovered \d+ messages", result.stdout)


def test_sigterm_finishes_the_recording(tmp_path):
    proc, out = _start_recording(tmp_path)
    _flown_to(proc, 2.0)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 143 and "terminated at sim time" in err and "finished and readable" in err
    assert _summary_ok(out)["/quad/pose"] > 60


def test_ctrl_c_finishes_the_recording(tmp_path):
    proc, out = _start_recording(tmp_path)
    _flown_to(proc, 2.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 130 and "interrupted at sim time" in err
    assert _summary_ok(out)["/quad/pose"] > 60


def test_a_signal_after_the_last_step_says_the_run_was_flown_whole(capsys):
    """A Ctrl-C that lands while a finished run writes its last bytes: still 130, but not
    'interrupted at sim time 60.00 s' as if the flight had been cut short."""
    import signal as signals

    from quadsim.apps.flying import report_end
    from quadsim.session.stopping import SignalStop

    with SignalStop() as stop:
        stop.signum = signals.SIGINT
        assert report_end(None, 60.0, planned_s=60.0) == 130
        assert report_end(None, 12.5, planned_s=60.0) == 130
    err = capsys.readouterr().err.splitlines()
    assert err == ["interrupted while finishing, after all 60.00 s were flown", "interrupted at sim time 12.50 s"]
