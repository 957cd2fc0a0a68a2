"""One module per command of the command line, each owning its options: `add_parser(sub)`
declares the command and its options (shared groups come from quadsim.apps.options), `main(args)`
carries it out and returns the exit code. `COMMANDS` is their order in `--help`."""

from __future__ import annotations

from quadsim.apps.commands import (
    bench,
    check,
    evaluate,
    examples,
    fly,
    info,
    recover,
    replay,
    run,
    scenarios,
    sweep,
)

COMMANDS = (run, fly, scenarios, evaluate, info, recover, replay, check, sweep, examples, bench)
