"""Data shipped with the package: vehicles (URDF + parameter files), worlds, textures, scenarios,
and the examples (`quadsim examples` lists and copies them).

Found through importlib.resources, so they are there from a clone, an editable install and an
installed wheel alike."""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def asset_path(*parts: str) -> Path:
    """The file system path of a shipped asset (packages are installed unzipped)."""
    return Path(str(resources.files(__name__).joinpath(*parts)))


#: the kinds of file the shipped examples are (programs, sweep and fleet files)
EXAMPLE_SUFFIXES = (".py", ".toml")


def shipped_examples() -> dict[str, Path]:
    """name -> path of each shipped example (`quadsim examples` lists and copies them)."""
    folder = asset_path("examples")
    return {p.name: p for p in sorted(folder.iterdir()) if p.suffix in EXAMPLE_SUFFIXES}
