"""The results table of a sweep: one row per run, sorted by run index, written atomically (a
Ctrl-C or a crash never leaves half a table), as Parquet when pyarrow is installed, else CSV.

Floats are written exactly (CSV: shortest repr, which reads back to the same float), so the same
sweep gives byte-identical tables whatever back-end or number of workers flew it.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any, BinaryIO

from quadsim.apps.sweep.metrics import METRICS
from quadsim.core.files import write_whole
from quadsim.core.invocation import install_extra
from quadsim.errors import QuadsimError

AXES = ("scenario", "airframe", "controller", "wind", "turbulence", "seed")
COLUMNS = ("index", "key", "settings", *AXES, *METRICS, "status", "failed_limits", "error", "recording")
_INTS = {"index", "seed"}
_FLOATS = set(METRICS)


def parquet_available() -> bool:
    """Whether pyarrow is installed, found without importing it: its import starts threads
    (jemalloc's, Arrow's pool), and a process with threads spawns its sweep workers instead of
    forking them (quadsim.apps.sweep.backends.start_method). An install that is found but does
    not import is said when the table is written (`write_table`)."""
    import importlib.util

    try:
        return importlib.util.find_spec("pyarrow") is not None
    except (ImportError, ValueError):
        return False


def table_path(folder: Path, fmt: str | None = None) -> Path:
    """results.parquet where pyarrow is installed (or asked for), else results.csv."""
    fmt = fmt or ("parquet" if parquet_available() else "csv")
    return folder / f"results.{fmt}"


def existing_table(folder: Path) -> Path | None:
    for name in ("results.parquet", "results.csv"):
        if (folder / name).is_file():
            return folder / name
    return None


def write_table(path: Path, rows: Iterable[dict[str, Any]]) -> None:
    ordered = sorted(rows, key=lambda r: r["index"])
    if path.suffix == ".parquet":
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError as exc:  # found, but broken: what was flown is kept all the same
            kept = path.with_suffix(".csv")
            write_table(kept, ordered)
            raise QuadsimError(
                f"pyarrow is installed but does not import ({exc}): the table was written as {kept} instead "
                "(--format csv chooses that)"
            ) from None
        columns = {c: [r.get(c) for r in ordered] for c in COLUMNS}
        schema = pa.schema(
            [(c, pa.int64() if c in _INTS else pa.float64() if c in _FLOATS else pa.string()) for c in COLUMNS]
        )
        table = pa.table(columns, schema=schema)
        write_whole(path, lambda fh: pq.write_table(table, fh))
    else:
        write_whole(path, lambda fh: _write_csv(fh, ordered))


def _write_csv(fh: BinaryIO, ordered: list[dict[str, Any]]) -> None:
    text = io.TextIOWrapper(fh, encoding="utf-8", newline="")
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(COLUMNS)
    for r in ordered:
        writer.writerow([_cell(r.get(c)) for c in COLUMNS])
    text.flush()
    text.detach()  # the file stays open for write_whole to finish


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(value)
    return str(value)


def read_table(path: Path) -> list[dict[str, Any]]:
    """The rows of a table written by `write_table` (for --resume, the summary and tests)."""
    try:
        if path.suffix == ".parquet":
            if not parquet_available():
                raise QuadsimError(
                    f"{path} is a Parquet table and pyarrow is not installed: {install_extra('parquet')}"
                )
            import pyarrow.parquet as pq

            return pq.read_table(path).to_pylist()
        with path.open(newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            if reader.fieldnames is None or "key" not in reader.fieldnames or "index" not in reader.fieldnames:
                raise QuadsimError(f"{path} is not a sweep results table (no index/key columns)")
            return [_typed(r) for r in reader]
    except QuadsimError:
        raise
    except Exception as exc:
        raise QuadsimError(f"cannot read the results table {path}: {exc}") from None


def _typed(row: dict[str, str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in row.items():
        if k in _INTS:
            out[k] = int(v)
        elif k in _FLOATS:
            out[k] = float(v) if v else math.nan
        else:
            out[k] = v
    return out
