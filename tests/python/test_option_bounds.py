"""Options refused where no road is (issue 38): each refused before any work, naming the option and
what it would have cost; a manifest's speed too."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex import ProcessingOptions, process
from roadtex.archive.options import MAX_SEGMENT_MODEL_POINTS
from roadtex.cli import main
from roadtex.errors import InvalidInputError, ManifestError


@pytest.fixture()
def one_run(tmp_path: Path) -> Path:
    path = roadtex.write_profile(roadtex.synthetic_pavement("dense_asphalt", 1.0, 0.5e-3, seed=1),
                                 tmp_path / "run.parquet")
    manifest = tmp_path / "manifest.csv"
    pl.DataFrame({"run_id": ["run"], "path": [str(path)]}).write_csv(manifest)
    return manifest


@pytest.mark.parametrize("flags, said", [
    (["--refine", "10000"], "refine must be at most 64"),
    (["--section-length", "1e-6"], "shorter than one ISO 13473-1 MPD baseline"),
    (["--speed", "1e300"], "faster than any road vehicle"),
    (["--moduli", "2", "2"], "more than once"),
    (["--overlap", "0.4999"], "between 0 and 0.75 of segment_length"),
])
def test_an_option_where_no_road_is_is_refused_before_any_work(one_run: Path, tmp_path: Path, flags: list[str],
                                                               said: str, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "out"
    assert main(["process", str(one_run), "--out", str(out), "--quiet", *flags]) == 2
    assert said in capsys.readouterr().err
    assert not (out / "runs").exists()   # nothing read, planned or solved


def test_a_model_grid_too_large_for_a_segment_is_that_run_s_recorded_failure(one_run: Path, tmp_path: Path) -> None:
    # 0.5 m segments at 0.5 mm are 1,000 readings: k = 64 is 64,000 points, within the cap; a 50 m
    # segment is not (6.4 million), refused before anything is allocated for it
    long_run = roadtex.write_profile(roadtex.synthetic_pavement("dense_asphalt", 52.0, 0.5e-3, seed=2),
                                     tmp_path / "long.parquet")
    options = ProcessingOptions(youngs_moduli=(2e6,), segment_length=50.0, refine=64, error_budget_db=None)
    summary = process(pl.DataFrame({"run_id": ["long"], "path": [str(long_run)]}), tmp_path / "out", options,
                      quiet=True)
    assert summary.failed == 1
    error = pl.read_parquet(tmp_path / "out" / "errors.parquet").row(0, named=True)
    assert error["stage"] == "segment" and f"above {MAX_SEGMENT_MODEL_POINTS:,}" in error["message"]
    assert "long.parquet" in error["message"]


def test_a_forced_k_too_large_for_a_surface_tile_is_refused_before_any_solve(tmp_path: Path) -> None:
    surface = roadtex.synthetic_surface("dense_asphalt", length=0.4, width=0.05, dx=1e-3, seed=1)
    np.save(tmp_path / "s.npy", surface.heights)
    manifest = pl.DataFrame({"run_id": ["s"], "path": [str(tmp_path / "s.npy")], "format": ["surface"],
                             "dx": [1e-3], "dy": [surface.dy]})
    options = ProcessingOptions(youngs_moduli=(2e6,), segment_length=0.4, refine=64, error_budget_db=None)
    assert process(manifest, tmp_path / "out", options, quiet=True).failed == 1
    error = pl.read_parquet(tmp_path / "out" / "errors.parquet").row(0, named=True)
    assert "times finer each way" in error["message"] and error["stage"] == "segment"


def test_a_manifest_speed_where_no_road_is_is_refused(one_run: Path, tmp_path: Path) -> None:
    manifest = pl.read_csv(one_run).with_columns(pl.lit(1e300).alias("speed_kmh"))
    with pytest.raises(ManifestError, match="faster than any road vehicle"):
        process(manifest, tmp_path / "out", ProcessingOptions(youngs_moduli=(2e6,)), quiet=True)


def test_the_python_api_refuses_as_the_command_line_does() -> None:
    for bad in ({"refine": 65}, {"section_length": 0.05}, {"speed_kmh": 401.0}, {"youngs_moduli": (2e6, 2e6)},
                {"segment_overlap": 0.4}):
        with pytest.raises(InvalidInputError):
            ProcessingOptions(**bad)   # type: ignore[arg-type]
    assert ProcessingOptions(segment_overlap=0.375).segment_overlap == 0.375   # 3/4 of 0.5 m: allowed
