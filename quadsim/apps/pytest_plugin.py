"""Recordings as pytest items: each `.mcap` under the configured folders re-flies as a test.

Installed with quadsim (the `pytest11` entry point), it collects nothing until told where the
recordings are, so it never changes another project's test run:

    # pyproject.toml
    [tool.pytest.ini_options]
    quadsim_recordings = ["tests/recordings"]   # folders (or files) whose .mcap files are tests
    quadsim_tolerance_m = "0.001"               # the defaults of `quadsim check`
    quadsim_tolerance_rad = "0.001"

Then `pytest`, `pytest tests/recordings`, `-k square`, `-x`, `-n 4` (pytest-xdist) and
`--junitxml` work on recordings as on any test. A `.mcap` named on the command line is collected
wherever it is. A recording that no longer re-flies fails with where and when the flight diverged
and by how much, against the tolerance; one that cannot be flown fails saying why. The work is
`quadsim check`'s own (apps/regression.py), one recording at a time.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from quadsim.apps.regression import DEFAULT_TOLERANCE_M, DEFAULT_TOLERANCE_RAD, CheckOutcome, CheckTask, check_one


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addini("quadsim_recordings", "folders or files whose .mcap recordings re-fly as tests", type="paths")
    parser.addini("quadsim_tolerance_m", f"position tolerance, m (default {DEFAULT_TOLERANCE_M})", default=None)
    parser.addini("quadsim_tolerance_rad", f"attitude tolerance, rad (default {DEFAULT_TOLERANCE_RAD})", default=None)
    group = parser.getgroup("quadsim", "quadsim recordings")
    group.addoption("--quadsim-tolerance-m", type=float, default=None, help="position tolerance for recordings, m")
    group.addoption("--quadsim-tolerance-rad", type=float, default=None, help="attitude tolerance for recordings, rad")


def pytest_configure(config: pytest.Config) -> None:
    """Settings are checked once, before anything is collected: a bad tolerance or a configured
    folder that is not there is one usage error (a tolerance was checked in each item, failing
    every test with pytest's internals; a misspelt folder collected nothing, silently)."""
    config.stash[_TOLERANCES] = (
        _tolerance(config, "tolerance_m", DEFAULT_TOLERANCE_M),
        _tolerance(config, "tolerance_rad", DEFAULT_TOLERANCE_RAD),
    )
    for folder in config.getini("quadsim_recordings"):
        if not Path(folder).exists():
            raise pytest.UsageError(f"quadsim_recordings names {folder}, which does not exist")


_TOLERANCES = pytest.StashKey[tuple[float, float]]()


def _tolerance(config: pytest.Config, name: str, default: float) -> float:
    given = config.getoption(f"--quadsim-{name.replace('_', '-')}")
    if given is None:
        text = config.getini(f"quadsim_{name}")
        try:
            given = float(text) if text else default
        except ValueError:
            raise pytest.UsageError(f"quadsim_{name} must be a number, got {text!r}") from None
    if not given >= 0:
        raise pytest.UsageError(f"quadsim_{name} (--quadsim-{name.replace('_', '-')}) must be 0 or more, got {given}")
    return float(given)


def _wanted(config: pytest.Config, path: Path) -> bool:
    """Under a configured folder, or named on the command line itself."""
    resolved = path.resolve()
    roots = [Path(p).resolve() for p in config.getini("quadsim_recordings")]
    if any(resolved == root or resolved.is_relative_to(root) for root in roots):
        return True
    named = [Path(arg.split("::")[0]) for arg in config.args]
    return any(resolved == (Path(config.invocation_params.dir) / arg).resolve() for arg in named)


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> pytest.Collector | None:
    if file_path.suffix == ".mcap" and _wanted(parent.config, file_path):
        return RecordingFile.from_parent(parent, path=file_path)
    return None


class RecordingFile(pytest.File):
    """One recording: one item, re-flying it."""

    def collect(self) -> list[RecordingItem]:
        return [RecordingItem.from_parent(self, name=self.path.stem)]


class Diverged(Exception):
    """The recording re-flew beyond the tolerance, or could not be flown."""

    def __init__(self, outcome: CheckOutcome) -> None:
        super().__init__("\n".join(outcome.lines))
        self.outcome = outcome


class RecordingItem(pytest.Item):
    def runtest(self) -> None:
        outcome = check_one(CheckTask(self.path, *self.config.stash[_TOLERANCES]))
        if outcome.status != "ok":
            raise Diverged(outcome)

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException], style: Any = None) -> str:
        if isinstance(excinfo.value, Diverged):  # its first line whole: pytest's short summary shows it
            first, *rest = excinfo.value.outcome.lines
            what = first.split(f"{self.path}: ", 1)[-1]
            if excinfo.value.outcome.status == "changed":
                m, rad = self.config.stash[_TOLERANCES]
                return f"{self.path.name} no longer re-flies within {m:g} m and {rad:g} rad: {what}\n" + "\n".join(rest)
            return f"{self.path.name} cannot be re-flown: {what}\n" + "\n".join(rest)
        return str(super().repr_failure(excinfo))

    def reportinfo(self) -> tuple[Path, int | None, str]:
        return self.path, None, f"re-fly {self.path.name}"
