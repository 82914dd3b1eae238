"""Parquet tables with a distance and a height column (found and scaled as for CSV)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl

from roadtex.errors import ProfileFormatError
from roadtex.profiles.plausibility import set_distance_unit
from roadtex.profiles.readers.delimited import ROADTEX_TAG
from roadtex.profiles.readers.grid import grid_positions
from roadtex.profiles.readers.limits import check_parquet_points
from roadtex.profiles.readers.npy import stored_record
from roadtex.profiles.readers.text import DISTANCE_NAMES, HEIGHT_NAMES, ReadResult, column_unit, pick_column, stated_unit


def read_parquet(path: Path, name: str, options: dict) -> ReadResult:
    """A Parquet profile's positions (m), heights (m), metadata, history and dx (m, or None); its
    declared size is checked first (:func:`~roadtex.profiles.readers.limits.check_parquet_points`)."""
    check_parquet_points(path, name)   # before polars allocates it: it aborts the process when it cannot
    try:
        frame = pl.read_parquet(path)
        stored_meta = pl.read_parquet_metadata(path)
    except Exception as exc:
        message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ProfileFormatError(f"{name}: not a readable Parquet file: {message}") from None
    if frame.height == 0:
        raise ProfileFormatError(f"{name}: Parquet table has no rows")
    metadata: dict[str, object] = {"format": "parquet"}
    history: list[str] = []
    options = dict(options)
    if ROADTEX_TAG in stored_meta:
        stored = stored_record(stored_meta[ROADTEX_TAG], lambda why: ProfileFormatError(
            f"{name}: damaged {ROADTEX_TAG} metadata: {why}"))
        metadata.update(stored.get("metadata", {}))
        history.extend(stored.get("history", []))
        if options.get("dx") is None:
            options["dx"] = stored.get("dx")
    names = frame.columns
    h_index = pick_column(names, options.get("height_column"), HEIGHT_NAMES, "height", True)
    d_index = pick_column(names, options.get("distance_column"), DISTANCE_NAMES, "distance", options.get("dx") is None)
    assert h_index is not None

    def column(index: int) -> np.ndarray:
        series = frame.get_column(names[index])
        if not series.dtype.is_numeric():
            raise ProfileFormatError(f"{name}: column {names[index]!r} is {series.dtype}, not numeric")
        return series.cast(pl.Float64).fill_null(float("nan")).to_numpy()

    heights = column(h_index) * column_unit(names, h_index, options.get("height_unit"), "height", source=name)
    set_distance_unit(metadata, stated_unit(names, d_index, options.get("distance_unit")))
    if d_index is None:
        return grid_positions(heights.size, options, name), heights, metadata, history, options.get("dx")
    positions = column(d_index) * column_unit(names, d_index, options.get("distance_unit"), "distance", source=name)
    return positions, heights, metadata, history, options.get("dx")
