"""`quadsim sweep`.

Its unit tests (in-process, one part at a time); the others are in tests/e2e/test_sweep.py."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from quadsim.apps.sweep.spec import load_sweep
from quadsim.apps.sweep.table import read_table
from quadsim.errors import ConfigError
from tests.e2e.test_sweep import SMALL, TRIO, _write


def test_the_runs_are_the_product_of_the_axes_in_order(tmp_path: Path) -> None:
    spec_file = tmp_path / "s.toml"
    spec_file.write_text("seeds = 2\n" + SMALL)
    spec = load_sweep(spec_file)
    assert len(spec.runs) == 2 * 3 * 2
    assert [r.index for r in spec.runs] == list(range(12))
    assert spec.runs[0].key == "scenario=hover airframe=quad controller=cascade wind=0,0 turbulence=none seed=0"
    assert spec.runs[1].seed == 1 and spec.runs[2].controller.name == "seed"
    assert spec.runs[4].controller.gains == (("velocity_p_xy_per_s", 0.8),)
    assert spec.varied == ("scenario", "controller")
    assert len({r.key for r in spec.runs}) == 12


def test_the_largest_runs_are_handed_out_first(tmp_path: Path, monkeypatch) -> None:
    """Work is handed out longest run first; the table keeps the sweep's order."""
    import quadsim.apps.sweep.execute as execute

    spec = load_sweep(_write(tmp_path, 'scenarios = ["takeoff", "climb", "yaw"]\n'))
    assert [run.sim_s for run in spec.runs] == [6.0, 10.5, 14.0]
    handed_out: list[str] = []

    def fly_in_order(fn, tasks, jobs, address, use_ray):
        handed_out.extend(task.run.scenario for task in tasks)
        return map(fn, tasks)

    monkeypatch.setattr(execute, "run_tasks", fly_in_order)
    result = execute.run_sweep(spec, tmp_path / "out", progress=False)
    assert handed_out == ["yaw", "climb", "takeoff"]
    assert [row["scenario"] for row in result.rows] == ["takeoff", "climb", "yaw"]
    assert [row["scenario"] for row in read_table(result.table)] == ["takeoff", "climb", "yaw"]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ('scenarios = ["trio.toml"]\nairframes = ["hexa"]\n', "'airframes' with a fleet file among the scenarios"),
        ('scenarios = ["trio.toml"]\n[controllers.c]\nkind = "seed"\n', "'controllers' with a fleet file"),
        (
            'scenarios = ["live.toml"]\n',
            "vehicle 'alpha' takes input = 'ros2'; in a sweep every vehicle flies a script",
        ),
        ('scenarios = ["idle.toml"]\n', "idle.toml: no vehicle flies a script: give duration_s"),
        ('scenarios = ["nowhere.toml"]\n', "fleet file not found"),
    ],
)
def test_a_sweep_refuses_a_fleet_it_cannot_fly(tmp_path: Path, text: str, expected: str) -> None:
    (tmp_path / "trio.toml").write_text(TRIO)
    (tmp_path / "live.toml").write_text('[[vehicle]]\nname = "alpha"\ninput = "ros2"\n')
    (tmp_path / "idle.toml").write_text('[[vehicle]]\nname = "alpha"\n')
    with pytest.raises(ConfigError, match=re.escape(expected)):
        load_sweep(_write(tmp_path, text))
