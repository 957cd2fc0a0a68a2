"""quadsim command-line entry from a clone: `.venv/bin/python main.py --help`. One run, top down:
quadsim/apps/launch.py, apps/cli.py, apps/commands/run.py, apps/plans.py (the RunPlan), apps/flying.py,
session/run.py (the Run), sim/fleet.py, sim/drone.py, sim/loop.py, physics/pybullet_world.py."""

# first of all, before any import of quadsim's: hold SIGINT and SIGTERM back until quadsim's
# entry point takes them (quadsim.apps.launch does the same; its main() lets them through)
try:
    import _signal as signal  # the C module: `signal` would first import enum, a few ms
except ImportError:
    import signal
if hasattr(signal, "pthread_sigmask"):
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})

import os
import sys

# quadsim is the package beside this file: importable even where Python leaves the script's
# folder off sys.path (-P, -I), so that a Python without the dependencies is told what to run
_here = os.path.dirname(os.path.realpath(__file__))
if _here not in sys.path:
    sys.path.insert(0, _here)

from quadsim.apps.launch import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
