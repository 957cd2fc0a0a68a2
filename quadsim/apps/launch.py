"""The program's entry point (the `quadsim` command, `python -m quadsim`, main.py).

It takes SIGINT and SIGTERM before anything heavy is imported, so a signal during start-up
ends the program as cleanly as one during a run: a line on stderr, exit 130 or 143.

When a window lost its X display (quadsim.apps.window.x11_guard), the process ends without
SDL's teardown, which would hang on the dead connection.
"""

from __future__ import annotations

import sys

from quadsim.session.stopping import SignalStop, StopRequested, describe, exit_code


def main(argv: list[str] | None = None) -> int:
    with SignalStop() as stop:
        try:
            from quadsim.apps.cli import main as cli_main
        except (StopRequested, ImportError) as exc:  # a second signal, or what it broke mid-import
            if stop.signum is None:
                raise
            print(f"quadsim: {describe(stop.signum)} while starting ({type(exc).__name__})", file=sys.stderr)
            return exit_code(stop.signum)
        code = cli_main(argv)
        # the work is done and every file finished: a signal from here on (while the interpreter
        # shuts down, when Python's defaults would kill it mid-flush) changes nothing
        stop.ignore_from_now()
    sys.stdout.flush()
    guard = sys.modules.get("quadsim.apps.window.x11_guard")
    if guard is not None and guard.display_lost():
        guard.end_process(code)
    return code
