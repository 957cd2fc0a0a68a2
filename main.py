"""quadsim command-line entry: `python main.py --help`."""

# first of all, before any import of quadsim's: hold SIGINT and SIGTERM back until quadsim's
# entry point takes them (quadsim.apps.launch does the same; its main() lets them through)
try:
    import _signal as signal  # the C module: `signal` would first import enum, a few ms
except ImportError:
    import signal
if hasattr(signal, "pthread_sigmask"):
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})

import sys

from quadsim.apps.launch import main

if __name__ == "__main__":
    sys.exit(main())
