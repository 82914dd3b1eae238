"""Reading a job's outputs back: what the bulk job wrote, by run and position."""

from __future__ import annotations

import os
from pathlib import Path

import polars as pl

from roadtex.errors import ResultsNotFoundError


def read_profiles(out_dir: str | os.PathLike[str], *, run_id: str | None = None, start: float | None = None,
                  end: float | None = None, youngs_modulus: float | None = None) -> pl.DataFrame:
    """Reads stitched enveloped profiles and pressures back, by run and position range (m).

    Needs a job run with ``keep_profiles=True``; columns as :data:`PROFILE_SCHEMA`.
    """
    root = Path(out_dir) / "runs"
    pattern = str(root / (run_id if run_id is not None else "*") / "profiles.parquet")
    if not any(root.glob(f"{run_id if run_id is not None else '*'}/profiles.parquet")):
        raise ResultsNotFoundError(f"no profiles under {root}{' for run ' + run_id if run_id else ''}; "
                                "process with keep_profiles=True (--keep-profiles)")
    query = pl.scan_parquet(pattern)
    if start is not None:
        query = query.filter(pl.col("position") >= start)
    if end is not None:
        query = query.filter(pl.col("position") < end)
    if youngs_modulus is not None:
        query = query.filter(pl.col("youngs_modulus") == float(youngs_modulus))
    return query.collect()

