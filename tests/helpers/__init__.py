"""What the tests share: the clone's paths (here), and, in their own modules, a runner for
`main.py` (cli), /proc readers (proc), the peers the end-to-end tests start (ros2_peer,
foxglove_client, ...) and smaller helpers. Not a test module."""

from pathlib import Path

#: the clone's root: main.py, quadsim/, docs/, examples/
ROOT = Path(__file__).resolve().parents[2]
#: the folder of the project's own regression recordings (a user may add flights there: a test
#: names the ones it uses, tests.helpers.recording.SHIPPED_RECORDINGS, never globs it)
RECORDINGS = ROOT / "tests" / "recordings"
#: this folder: the peers and scripts the tests start by path (foxglove_client.py, ros2_peer.py, ...)
HELPERS = Path(__file__).resolve().parent
