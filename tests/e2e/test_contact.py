"""Contact.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_contact.py."""

import re
import subprocess
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from tests.helpers import ROOT


def test_crash_reset_and_events_in_the_recording_and_the_api(tmp_path):
    # the real path: the CLI flies a script into the tower with --reset-on-crash and records it
    script = tmp_path / "tower.qscript"
    script.write_text("z_mode velocity\n1.5 linear.z=1.0\n4.0 linear.x=2.0\n1.0\n")
    out = tmp_path / "tower.mcap"
    cmd = [sys.executable, str(ROOT / "main.py"), "run", "--script", str(script), "--cameras", "none"]
    result = subprocess.run([*cmd, "--reset-on-crash", "--out", str(out)], capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    assert "flight events   1 takeoff, 1 crash, 1 reset" in result.stdout
    assert re.search(r"crash           at t=\d\.\d\d s: hit red_tower at [12]\.\d\d m/s \(side\)", result.stdout)
    with open(out, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        rosout = [(m.log_time, d) for _, _, m, d in reader.iter_decoded_messages(topics=["/rosout"])]
        poses = [d for _, _, _, d in reader.iter_decoded_messages(topics=["/quad/pose"])]
    texts = [d.msg for _, d in rosout if not d.msg.startswith("recording: ")]
    assert texts[0] == "takeoff: climbing from the ground"
    crash = next(d for _, d in rosout if d.msg.startswith("crash: hit red_tower at "))
    assert crash.level == 30  # WARN
    assert texts[-1] == "reset: back at the start after a crash"
    end = poses[-1].pose.position
    assert abs(end.x) < 0.01 and abs(end.y) < 0.01 and end.z < 0.06  # back at the start, landed
    # the recording re-flies, reset and all
    check = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "check", str(out)], capture_output=True, text=True, cwd=ROOT
    )
    assert check.returncode == 0, check.stdout + check.stderr
