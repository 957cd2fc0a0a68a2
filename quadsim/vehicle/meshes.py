"""A URDF's mesh files as PyBullet can load them: an ASCII STL written again as a binary STL, a mesh
PyBullet cannot load refused in one line naming it.

PyBullet reads binary STL only: a part drawn from an ASCII STL (which RViz and Foxglove draw) was
left out of the physics and the camera images with nothing but PyBullet's own b3Warning lines. So
before PyBullet sees a URDF, each ASCII STL it names is converted (bounded in size and triangles,
each facet checked), to a binary STL in quadsim's cache named by the ASCII file's content, and
PyBullet loads a copy of the URDF that names the converted files (every other file by its full
path). A URDF whose meshes PyBullet reads as they are is loaded as it is. What PyBullet cannot
load at all (a mesh that is not STL, OBJ or COLLADA; an STL that is neither a whole binary STL
nor ASCII STL) is refused.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
import struct
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

from quadsim.core.files import write_whole
from quadsim.errors import ConfigError

#: the mesh kinds PyBullet's URDF importer loads (by file name, as it tells them apart)
PYBULLET_MESH_SUFFIXES = (".stl", ".obj", ".dae")
#: an ASCII STL larger than this is refused (about 130,000 triangles): it is read line by line here
MAX_ASCII_STL_BYTES = 32 * 1024 * 1024
#: an STL with more triangles than this is refused (a binary STL of that many is 100 MB)
MAX_STL_TRIANGLES = 2_000_000
#: no line of an ASCII STL is longer than this
MAX_STL_LINE_BYTES = 1024
_BINARY_HEADER_BYTES, _BINARY_TRIANGLE_BYTES = 84, 50


def pybullet_urdf(urdf: Path) -> Path:
    """The URDF PyBullet should load for `urdf` (read and checked already, its mesh files there):
    `urdf` itself, or a copy naming binary STL versions of its ASCII STL meshes."""
    root = ET.parse(urdf).getroot()
    converted: dict[str, Path] = {}
    for mesh in root.iter("mesh"):
        name = mesh.get("filename", "")
        path = urdf.parent / name
        suffix = path.suffix.lower()
        if suffix not in PYBULLET_MESH_SUFFIXES:
            raise ConfigError(
                f"{urdf.name}: mesh {name!r}: PyBullet loads STL, OBJ and COLLADA (.dae) meshes, not {suffix or 'this'}"
                " files: convert it to one of those"
            )
        if suffix == ".stl" and name not in converted and _stl_kind(path) == "ascii":
            converted[name] = _binary_copy(path)
    if not converted:
        return urdf
    for element in root.iter():
        named = element.get("filename")
        if element.tag in ("mesh", "texture") and named:  # the copy lives elsewhere: every file by its full path
            element.set("filename", str(converted.get(named) or (urdf.parent / named).resolve()))
    text = ET.tostring(root, encoding="unicode")
    return _cached(f"{urdf.stem}-{_digest(text.encode())}.urdf", text.encode(), urdf)


def _stl_kind(path: Path) -> str:
    """ "binary" for a whole binary STL, "ascii" for what can only be ASCII STL; refused otherwise."""
    size = path.stat().st_size
    with path.open("rb") as fh:
        head = fh.read(_BINARY_HEADER_BYTES)
    if size >= _BINARY_HEADER_BYTES:
        (count,) = struct.unpack_from("<I", head, 80)
        if size == _BINARY_HEADER_BYTES + _BINARY_TRIANGLE_BYTES * count:  # may begin with "solid" as well
            if count > MAX_STL_TRIANGLES:
                raise ConfigError(f"{path}: {count} triangles, more than the {MAX_STL_TRIANGLES} an STL may have here")
            return "binary"
    if head.lstrip().startswith(b"solid"):
        return "ascii"
    raise ConfigError(
        f"{path}: not an STL PyBullet can read: not ASCII STL, and a binary STL of the {size} bytes it has would be "
        f"84 + 50 bytes a triangle (cut short or damaged?)"
    )


def _binary_copy(ascii_stl: Path) -> Path:
    """A binary STL of the same triangles, in the cache (made once for the file's content)."""
    size = ascii_stl.stat().st_size
    if size > MAX_ASCII_STL_BYTES:
        raise ConfigError(
            f"{ascii_stl}: an ASCII STL of {size / 2**20:.1f} MiB, more than the {MAX_ASCII_STL_BYTES // 2**20} MiB "
            "converted here for PyBullet (which reads binary STL only): save it as binary STL"
        )
    data = ascii_stl.read_bytes()
    name = f"{ascii_stl.stem}-{_digest(data)}.stl"
    ready = cache_dir() / "meshes" / name
    if ready.is_file():
        return ready
    return _cached(name, _binary_stl(ascii_stl, data), ascii_stl, "meshes")


def _binary_stl(path: Path, data: bytes) -> bytes:
    """The triangles of an ASCII STL as a binary STL (normals from the vertices, counter-clockwise
    seen from outside, as STL has them); a malformed file is refused naming the line."""
    triangles: list[bytes] = []
    facet: list[tuple[float, float, float]] | None = None
    solid = False
    for number, raw in enumerate(data.splitlines(), start=1):
        if len(raw) > MAX_STL_LINE_BYTES:
            raise ConfigError(f"{path}: line {number} is longer than {MAX_STL_LINE_BYTES} bytes: not an ASCII STL")
        words = raw.split()
        keyword = words[0].lower() if words else b""
        if keyword == b"solid":
            solid = True
        elif keyword == b"facet":
            facet = []
        elif keyword == b"vertex" and facet is not None and len(words) == 4:
            facet.append(_point(words[1:], path, number))
        elif keyword == b"endfacet" and facet is not None:
            if len(facet) != 3:
                raise ConfigError(f"{path}: line {number}: a facet with {len(facet)} vertices (an STL facet has 3)")
            triangles.append(_triangle(facet))
            facet = None
            if len(triangles) > MAX_STL_TRIANGLES:
                raise ConfigError(f"{path}: more than the {MAX_STL_TRIANGLES} triangles an STL may have here")
        elif keyword not in (b"", b"outer", b"endloop", b"endsolid"):
            raise ConfigError(f"{path}: line {number}: {raw[:40].decode(errors='replace')!r} is not ASCII STL")
    if not solid or not triangles or facet is not None:
        raise ConfigError(f"{path}: not an ASCII STL with whole facets (solid ... facet ... endfacet ... endsolid)")
    header = b"binary copy of an ASCII STL, made by quadsim for PyBullet".ljust(80, b" ")
    return header + struct.pack("<I", len(triangles)) + b"".join(triangles)


def _point(words: list[bytes], path: Path, number: int) -> tuple[float, float, float]:
    try:
        x, y, z = (float(w) for w in words)
    except ValueError:
        raise ConfigError(f"{path}: line {number}: a vertex needs three numbers") from None
    if not all(math.isfinite(v) for v in (x, y, z)):
        raise ConfigError(f"{path}: line {number}: a vertex that is not a finite number")
    return x, y, z


def _triangle(facet: list[tuple[float, float, float]]) -> bytes:
    """One binary STL record: the unit normal, the three vertices, no attributes."""
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = facet
    ux, uy, uz, vx, vy, vz = bx - ax, by - ay, bz - az, cx - ax, cy - ay, cz - az
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    length = math.sqrt(nx * nx + ny * ny + nz * nz) or 1.0
    return struct.pack("<12fH", nx / length, ny / length, nz / length, ax, ay, az, bx, by, bz, cx, cy, cz, 0)


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()[:16]


def cache_dir() -> Path:
    """quadsim's folder in the user's cache (XDG_CACHE_HOME, else ~/.cache): files made once and
    shared by every process, named by their content."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "quadsim"


_private: list[Path] = []  # this process's own temporary folder, when the cache cannot be written


def _cached(name: str, data: bytes, source: Path, folder: str = "urdf") -> Path:
    """`data` as file `name` in the cache's `folder`, written whole or not at all (render workers
    read it too); else in a temporary folder of this process's own (left for the system to clear)."""
    target = cache_dir() / folder / name
    if target.is_file():
        return target
    with contextlib.suppress(OSError):  # then the temporary folder below
        if not cache_dir().parent.parent.is_dir():  # no home (HOME=/nonexistent): none is made for it
            raise NotADirectoryError(cache_dir())
        target.parent.mkdir(parents=True, exist_ok=True)
        write_whole(target, lambda fh: fh.write(data))  # another process never reads half of it
        return target
    try:
        if not _private:
            _private.append(Path(tempfile.mkdtemp(prefix="quadsim-meshes-")))
        target = _private[0] / name
        target.write_bytes(data)
    except OSError as exc:
        raise ConfigError(f"{source}: could not write the copy PyBullet needs of it ({exc.strerror or exc})") from None
    return target
