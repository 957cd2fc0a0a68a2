"""Where a recording lands without --out: $QUADSIM_RECORDINGS, a source checkout's recordings/, else
the user's data folder; never the current directory of an installed package."""

from __future__ import annotations

from pathlib import Path

import pytest

from quadsim.recording.paths import ENV_VAR, default_recordings_dir, source_checkout, user_data_dir
from tests.helpers import ROOT


@pytest.fixture
def no_override(monkeypatch):
    monkeypatch.delenv(ENV_VAR, raising=False)


def fake_checkout(root: Path, name: str = "quadsim", recordings: bool = True) -> Path:
    """A folder laid out like a clone; returns its package folder."""
    (root / "quadsim").mkdir(parents=True)
    (root / "pyproject.toml").write_text(f'[project]\nname = "{name}"\n')
    if recordings:
        (root / "recordings").mkdir()
    return root / "quadsim"


def test_the_environment_variable_wins(monkeypatch, tmp_path):
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "mine"))
    assert default_recordings_dir(fake_checkout(tmp_path / "clone")) == tmp_path / "mine"
    monkeypatch.setenv(ENV_VAR, "~/flights")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert default_recordings_dir() == tmp_path / "home" / "flights"


def test_an_empty_variable_is_not_set(monkeypatch, tmp_path):
    monkeypatch.setenv(ENV_VAR, "")
    assert default_recordings_dir(fake_checkout(tmp_path)) == tmp_path / "recordings"


def test_a_source_checkout_keeps_its_recordings_in_its_own_folder(no_override, tmp_path):
    package = fake_checkout(tmp_path / "clone")
    assert source_checkout(package) == tmp_path / "clone"
    assert default_recordings_dir(package) == tmp_path / "clone" / "recordings"


def test_this_repository_is_a_checkout(no_override, monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)  # whatever the current directory
    assert default_recordings_dir() == ROOT / "recordings"


@pytest.mark.parametrize(
    "layout",
    [
        {"name": "someone-else"},  # another project's checkout
        {"recordings": False},  # no recordings/ folder
    ],
)
def test_not_a_checkout_falls_back_to_the_user_folder(no_override, monkeypatch, tmp_path, layout):
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    package = fake_checkout(tmp_path / "clone", **layout)
    assert source_checkout(package) is None
    assert default_recordings_dir(package) == tmp_path / "data" / "quadsim" / "recordings"


def test_an_installed_package_uses_the_user_data_folder(no_override, monkeypatch, tmp_path):
    site_packages = tmp_path / "venv" / "lib" / "site-packages"
    (site_packages / "quadsim").mkdir(parents=True)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.delenv("XDG_DATA_HOME", raising=False)
    expected = tmp_path / "home" / ".local" / "share" / "quadsim" / "recordings"
    assert default_recordings_dir(site_packages / "quadsim") == expected
    monkeypatch.setenv("XDG_DATA_HOME", "relative/data")  # invalid by the XDG spec: ignored
    assert default_recordings_dir(site_packages / "quadsim") == expected
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    assert default_recordings_dir(site_packages / "quadsim") == tmp_path / "data" / "quadsim" / "recordings"


def test_a_broken_pyproject_is_not_a_checkout(tmp_path):
    package = fake_checkout(tmp_path)
    (tmp_path / "pyproject.toml").write_text("[project\nname = ")
    assert source_checkout(package) is None


def test_other_platforms(monkeypatch, tmp_path):
    monkeypatch.setenv("HOME", str(tmp_path))
    assert user_data_dir("darwin") == tmp_path / "Library" / "Application Support" / "quadsim"
    monkeypatch.setenv("LOCALAPPDATA", str(tmp_path / "Local"))
    assert user_data_dir("win32") == tmp_path / "Local" / "quadsim"


def test_a_run_without_out_lands_in_the_default_folder(monkeypatch, tmp_path):
    from quadsim.recording.writer import recording_path

    monkeypatch.setenv(ENV_VAR, str(tmp_path / "runs"))
    monkeypatch.chdir(tmp_path)
    path = recording_path(None, "square cascade")
    assert path.parent == tmp_path / "runs" and path.name.endswith("_square-cascade.mcap")
    assert recording_path(Path("here.mcap"), "x") == Path("here.mcap")  # --out still decides


def test_out_file_names_the_first_recording_and_numbers_the_later_ones(tmp_path):
    """--out FILE.mcap in the window: F5 or a reset starts FILE-2.mcap, then FILE-3.mcap, beside
    it (a dated name lost the user's name), skipping names that are taken."""
    from quadsim import SimConfig, Simulator
    from quadsim.session.outputs import OutputOptions, RecordedRun

    (tmp_path / "mine-2.mcap").write_bytes(b"someone else's")
    with Simulator(SimConfig()) as sim:
        session = RecordedRun(sim, OutputOptions(out=tmp_path / "mine.mcap", cameras=()), "t", {})
        paths = [session.path]
        for _ in range(2):
            session.stop_recording()
            sim.step(10)
            paths.append(session.start_recording())
        session.close()
    assert [p.name for p in paths] == ["mine.mcap", "mine-3.mcap", "mine-4.mcap"]
    assert (tmp_path / "mine-2.mcap").read_bytes() == b"someone else's"
