"""The program's entry point (the `quadsim` command, `python -m quadsim`, main.py); the command
line itself is quadsim.apps.cli.

Its first statement holds SIGINT and SIGTERM back (blocks them), before anything else is
imported; main() installs SignalStop, then lets them through. A signal in between waits, so it
is never turned into a KeyboardInterrupt in the middle of an import (a traceback), nor into an
exception that a weakref callback would swallow: main() finds it pending and ends the program as
a signal during start-up does, a line on stderr and exit 130 or 143. What runs before that
first statement is Python's own start-up (and, for the `quadsim` command, the `import re` of
the script pip wrote; for `python -m quadsim`, runpy's imports), then the light
`quadsim/__init__.py`: well under a millisecond of quadsim's.

Importing this module is launching the program (until main() runs, the two signals wait): it
is the entry point, not a library module.

When a window lost its X display (quadsim.apps.window.x11_guard), the process ends without
SDL's teardown, which would hang on the dead connection.
"""

import sys

try:  # the C module: `signal` itself first imports enum, a few ms more with Python's default handler
    import _signal as _early  # type: ignore[import-not-found]  # (no stub: the same functions as signal)
except ImportError:  # another Python than CPython
    import signal as _early

_HELD = {_early.SIGINT, _early.SIGTERM, *((_early.SIGHUP,) if hasattr(_early, "SIGHUP") else ())}
_CAN_HOLD = hasattr(_early, "pthread_sigmask") and hasattr(_early, "sigpending")  # POSIX
if _CAN_HOLD:  # (this thread only: no other one exists yet)
    _early.pthread_sigmask(_early.SIG_BLOCK, _HELD)

import os  # noqa: E402  (already loaded by Python's start-up)

# quadsim's arrays are 3-vectors and small images: OpenBLAS's thread pool (numpy starts it on
# import) serves nothing here and makes the process multi-threaded, which rules out forking the
# sweep pool's workers (quadsim.apps.sweep.backends.start_method). A value the user set stays.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from quadsim.session.stopping import SignalStop, StopRequested, describe, exit_code  # noqa: E402


def _signalled_while_held(stop: SignalStop) -> int | None:
    """Let SIGINT and SIGTERM through, now that `stop` takes them. One that came while they were
    held is dropped (set to be ignored) and returned: the program ends at once."""
    if not _CAN_HOLD:
        return None
    pending = sorted(_HELD & _early.sigpending())
    if pending:
        stop.ignore_from_now()  # discards the pending ones: the program is ending
    _early.pthread_sigmask(_early.SIG_UNBLOCK, _HELD)
    return pending[0] if pending else None


def main(argv: list[str] | None = None) -> int:
    with SignalStop() as stop:
        try:
            early = _signalled_while_held(stop)
            if early is not None:
                print(f"quadsim: {describe(early)} while starting", file=sys.stderr)
                return exit_code(early)
            from quadsim.core.invocation import missing_modules, missing_modules_message

            missing = missing_modules()  # said in one line, not as a traceback from deep in a command
            if missing:
                print(f"quadsim: error: {missing_modules_message(missing)}", file=sys.stderr)
                return 2
            from quadsim.apps.cli import main as cli_main
        except (StopRequested, ImportError) as exc:  # a second signal, or what it broke mid-import
            if stop.signum is None:
                raise
            print(f"quadsim: {describe(stop.signum)} while starting ({type(exc).__name__})", file=sys.stderr)
            stop.ignore_from_now()  # the program is ending: a further signal changes nothing
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
