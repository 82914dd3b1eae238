"""The spacing across the road of a surface (issue 38): rows 1 m apart (a manifest dy = 1 for a
1 mm scan, an X3P CY increment in the wrong unit) were never judged, and such a run went past
100 s at full CPU. roadtex.profiles.plausibility.implausible_across judges it; the reader warns,
the manifest warns, and the job refuses the run at "read" before any solve."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from roadtex.archive import ProcessingOptions, build_manifest, process
from roadtex.errors import ImplausibleTextureWarning
from roadtex.profiles.plausibility import implausible_across
from roadtex.surfaces import read_surface, synthetic_surface
from test_x3p import write_x3p

SCAN = synthetic_surface("dense_asphalt", 0.4, 0.05, 1e-3, seed=3)   # 50 rows, 1 mm apart


@pytest.mark.parametrize("dy, rows, tile, words", [
    (1.0, 50, None, "its 50 rows across the road are 1 m apart, further apart than the longest texture wavelength"),
    (0.3, 10, 0.2, "further apart than the tile length (--segment-length) (0.2 m)"),
    (3e-3, 2000, None, "6 m wide in all, wider than a lane (5 m)"),
    (float("nan"), 10, None, "is not a positive number"),
    (1e-9, 5, None, "5 rows across the road are 1e-09 m apart, finer than 1e-06 m"),   # an OpenCRG header's 1e-9
])
def test_rows_too_far_apart_or_too_wide_are_named(dy: float, rows: int, tile: float | None, words: str) -> None:
    reason = implausible_across(dy, rows, "scan.npy", tile_length=tile)
    assert reason is not None and reason.startswith("scan.npy: ") and words in reason


@pytest.mark.parametrize("dy, rows", [(1e-3, 50), (0.02, 100), (0.1, 30), (0.5e-3, 8000)])
def test_coarse_rows_within_a_lane_are_not_judged(dy: float, rows: int) -> None:
    # multi-laser arrays space their lines 10 to 100 mm apart: coarse, not implausible
    assert implausible_across(dy, rows, "scan.npy", tile_length=0.2 if dy < 0.2 else None) is None


def test_the_reader_warns_of_rows_a_metre_apart_whatever_the_unit(tmp_path: Path) -> None:
    np.save(tmp_path / "scan.npy", SCAN.heights)
    with pytest.warns(ImplausibleTextureWarning, match="rows across the road are 1 m apart"):
        read_surface(tmp_path / "scan.npy", dx=1e-3, dy=1.0)
    x3p = write_x3p(tmp_path / "scan.x3p", SCAN.heights, dx=1e-3, dy=1.0)   # X3P states metres: certain, still no scan
    with pytest.warns(ImplausibleTextureWarning, match="rows across the road are 1 m apart"):
        read_surface(x3p)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleTextureWarning)
        read_surface(tmp_path / "scan.npy", dx=1e-3, dy=1e-3)


def test_the_manifest_warns_and_the_job_refuses_the_run_before_solving(tmp_path: Path) -> None:
    data = tmp_path / "data"
    data.mkdir()
    write_x3p(data / "wide.x3p", SCAN.heights, dx=1e-3, dy=1.0)
    with pytest.warns(ImplausibleTextureWarning, match="wide.x3p: its 50 rows across the road are 1 m apart"):
        manifest = build_manifest(data)
    options = ProcessingOptions(segment_length=0.2, youngs_moduli=(2e6,), tol=1e-8, error_budget_db=None)
    summary = process(manifest, tmp_path / "out", options, quiet=True)
    assert summary.failed == 1
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet")
    assert errors["stage"].to_list() == ["read"]
    assert "1 m apart, further apart than the longest texture wavelength (0.5 m) and the tile length" in errors["message"][0]
    assert not (tmp_path / "out" / "segments.parquet").exists() or pl.read_parquet(tmp_path / "out" / "segments.parquet").height == 0
