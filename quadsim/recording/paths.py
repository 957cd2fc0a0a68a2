"""Where recordings go when no `--out` is given.

In order: the folder named by $QUADSIM_RECORDINGS; the `recordings/` folder of the source checkout
quadsim runs from (a clone, editable install or not); else a per-user data folder
(`$XDG_DATA_HOME/quadsim/recordings`, by default `~/.local/share/quadsim/recordings`; on macOS
`~/Library/Application Support/quadsim/recordings`, on Windows `%LOCALAPPDATA%\\quadsim\\recordings`).
An installed package never writes into the current directory or into site-packages.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from quadsim.core.toml_files import tomllib

#: set it to a folder to send every recording made without --out there
ENV_VAR = "QUADSIM_RECORDINGS"
PROJECT_NAME = "quadsim"
_PACKAGE_DIR = Path(__file__).resolve().parent.parent


def default_recordings_dir(package_dir: Path | None = None) -> Path:
    """The folder a recording lands in without `--out` (read each call: the environment may change)."""
    override = os.environ.get(ENV_VAR)
    if override:
        return Path(override).expanduser()
    checkout = source_checkout(package_dir)
    if checkout is not None:
        return checkout / "recordings"
    return user_data_dir() / "recordings"


def source_checkout(package_dir: Path | None = None) -> Path | None:
    """The root of the source checkout that holds the quadsim package, or None for an installed one.

    A checkout is the package folder's parent holding a pyproject.toml that names the project
    "quadsim" and a `recordings/` folder (the clone ships it, empty)."""
    root = (package_dir if package_dir is not None else _PACKAGE_DIR).resolve().parent
    if not (root / "recordings").is_dir():
        return None
    try:
        project = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8")).get("project", {})
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    return root if isinstance(project, dict) and project.get("name") == PROJECT_NAME else None


def user_data_dir(platform: str = sys.platform) -> Path:
    """quadsim's per-user data folder, where the platform keeps application data."""
    if platform == "win32":
        local = os.environ.get("LOCALAPPDATA") or os.environ.get("APPDATA")
        return (Path(local) if local else Path.home() / "AppData" / "Local") / "quadsim"
    if platform == "darwin":
        return Path.home() / "Library" / "Application Support" / "quadsim"
    xdg = os.environ.get("XDG_DATA_HOME")
    # the XDG spec: a relative path is invalid and is to be ignored
    base = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".local" / "share"
    return base / "quadsim"
