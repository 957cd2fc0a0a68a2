"""quadsim command-line entry: `python main.py --help`."""

import signal
import sys


def _stop_while_starting(signum: int, frame: object) -> None:
    """A signal before quadsim's own handlers exist (quadsim.apps.launch installs them as soon
    as it is imported) ends the program as one during start-up does: a line, exit 130 or 143."""
    print(f"quadsim: {'interrupted' if signum == signal.SIGINT else 'terminated'} while starting", file=sys.stderr)
    raise SystemExit(128 + signum)


# first of all, before any import of quadsim's
signal.signal(signal.SIGINT, _stop_while_starting)
signal.signal(signal.SIGTERM, _stop_while_starting)

from quadsim.apps.launch import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
