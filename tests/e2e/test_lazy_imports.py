"""A run imports only what it uses: without cameras and recording, none of the recording and
imaging libraries (they cost start-up time and memory)."""

import json
import subprocess
import sys

from tests.helpers import ROOT

#: the libraries, or the parts of one, that cost: mcap's own reader and writer (its records, 20 ms,
#: and the decompressors), not its table of record opcodes (1 ms), which the damage-tolerant
#: reader names records by
HEAVY = ("rosbags", "mcap.records", "mcap.reader", "mcap.writer", "mcap_ros2", "foxglove", "cv2")

PROBE = f"""
import json, sys
from quadsim.apps.cli import main
code = main(sys.argv[1:])
loaded = sorted({{heavy.split(".")[0] for heavy in {HEAVY!r} if heavy in sys.modules}})
print(json.dumps({{"code": code, "loaded": loaded}}))
"""


def _modules_after(*args: str) -> dict:
    out = subprocess.run([sys.executable, "-c", PROBE, *args], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_an_unrecorded_run_without_cameras_imports_no_recording_or_imaging_library(tmp_path):
    bare = _modules_after("run", "--script", "hover", "--cameras", "none", "--no-record")
    assert bare == {"code": 0, "loaded": []}
    # the probe sees them when they are used
    recorded = _modules_after(
        "run", "--script", "hover", "--cameras", "none", "--duration", "1", "--out", str(tmp_path)
    )
    assert recorded["code"] == 0 and {"foxglove", "rosbags"} <= set(recorded["loaded"])
