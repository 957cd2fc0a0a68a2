"""Contact: a crash into the tower and the reset after it, and vehicles of a fleet flown into
each other, as the command line flies, records and re-flies them.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_contact.py."""

import re
import subprocess
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from tests.helpers import ROOT
from tests.helpers.fleets import fleet_toml, vehicle
from tests.helpers.mcap import decoded_messages
from tests.integration.test_cli import cli


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


COLLISION = fleet_toml(
    vehicle("alpha", (0.0, 0.0, 0.0, 0.0), input="script:ram.qscript"),
    vehicle("bravo", (3.0, 0.0, 0.0, 180.0), input="script:hold.qscript"),
)


def test_two_vehicles_flown_into_each_other_both_crash_and_the_recording_refies(tmp_path):
    (tmp_path / "ram.qscript").write_text("z_mode height\n3.0 linear.z=0\n3.0 linear.x=2.0\n")
    (tmp_path / "hold.qscript").write_text("z_mode height\n6.0 linear.z=0\n")
    (tmp_path / "ram.toml").write_text(COLLISION)
    out = cli("run", "--fleet", str(tmp_path / "ram.toml"), "--out", str(tmp_path / "ram.mcap"))
    assert out.returncode == 0, out.stderr
    crash_lines = [line.split() for line in out.stdout.splitlines() if line.split()[1:2] == ["crash"]]
    assert [line[0] for line in crash_lines] == ["alpha", "bravo"], out.stdout  # each under its vehicle's name
    assert "bravo" in crash_lines[0] and "alpha" in crash_lines[1], out.stdout  # each names the other
    rosout = [m for _, _, m in decoded_messages(tmp_path / "ram.mcap", ["/rosout"])]
    crashes = {m.name: m for m in rosout if m.msg.startswith("crash")}
    assert set(crashes) == {"alpha.quadsim", "bravo.quadsim"}
    assert "hit bravo" in crashes["alpha.quadsim"].msg and "hit alpha" in crashes["bravo.quadsim"].msg
    assert {m.level for m in crashes.values()} == {30}  # WARN
    assert crashes["alpha.quadsim"].stamp == crashes["bravo.quadsim"].stamp  # the same step
    out = cli("check", str(tmp_path / "ram.mcap"), "--tolerance-m", "0", "--tolerance-rad", "0")
    assert out.returncode == 0 and "flies again identically" in out.stdout, out.stdout + out.stderr
