"""The most values a data file may declare: checked against what its header or metadata declares
(a ``.npy`` header's shape, a Parquet footer's row and column counts, an X3P ``main.xml``'s grid)
before anything is read, inflated or allocated. A 3.5 MB Parquet file can declare 400 million rows
and a sparse ``.npy`` 16 GB of values: polars aborts the process on such an allocation (nothing can
catch it) and numpy raises a MemoryError that names no file, so they are refused here, unread,
with a ProfileFormatError naming the file."""

from __future__ import annotations

from pathlib import Path

import polars as pl

from roadtex.errors import ProfileFormatError

#: The most values (points: heights, distances, positions) a profile or surface file may declare:
#: 2**27 (134 million; 1 GiB as float64, a 4 m x 33 m lane at 1 mm, a 67 km profile at 0.5 mm).
#: A larger file is refused before its data is read: split it.
MAX_POINTS = 2**27


def shown(count: int) -> str:
    """A count as a message shows it (a forged 1e300 is no 301-digit message)."""
    return f"{count:,}" if count < 10**15 else f"{float(count):.3g}"


def check_points(name: str, count: int, declared: str) -> None:
    """Refuses a file whose ``declared`` size (what its header or metadata states: "its header's
    shape (20000, 100000)") holds more than :data:`MAX_POINTS` values, naming the file."""
    if count > MAX_POINTS:
        raise ProfileFormatError(f"{name}: {declared} declares {shown(count)} values, beyond the {shown(MAX_POINTS)} a "
                                 "profile or surface file may hold here (roadtex.profiles.readers.limits.MAX_POINTS; "
                                 "refused before its data is read): split the file")


def parquet_size(path: Path, name: str) -> tuple[int, int]:
    """(rows, columns) a Parquet file's footer declares, read without its data."""
    try:
        rows = int(pl.scan_parquet(path).select(pl.len()).collect().item())
        columns = len(pl.read_parquet_schema(path))
    except Exception as exc:  # noqa: BLE001 - polars raises several exception types for malformed files
        message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ProfileFormatError(f"{name}: not a readable Parquet file: {message}") from None
    return rows, columns


def check_parquet_points(path: Path, name: str) -> None:
    """Refuses a Parquet file whose footer declares more than :data:`MAX_POINTS` values (rows
    times columns: polars reads every column), before its data is read."""
    rows, columns = parquet_size(path, name)
    check_points(name, rows * columns, f"its Parquet metadata ({shown(rows)} rows x {columns} columns)")
