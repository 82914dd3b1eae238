"""The job's plan (its error-budget pilot of line runs) is stated only where it applies: surface
runs carry none of its estimates; a pilot that could not run is recorded, not dropped."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from roadtex.archive import ProcessingOptions, process
from roadtex.archive import plan as plan_module
from roadtex.errors import ErrorBudgetWarning
from roadtex.profiles import write_profile
from roadtex.profiles.pavements import synthetic_pavement
from roadtex.surfaces import synthetic_surface

OPTIONS = ProcessingOptions(youngs_moduli=(2e6, 1e7), segment_length=0.128, tol=1e-8)
PLAN_RUN_COLUMNS = ("worst_level_error_db", "within_budget", "speedup", "time_saved_fraction")


def mixed_manifest(folder: Path) -> pl.DataFrame:
    """One line run (0.5 mm) and one surface run (1 mm) of the same pavement and device."""
    line = write_profile(synthetic_pavement("dense_asphalt", 0.6, 5e-4, seed=1), folder / "line.csv")
    surface = folder / "surface.npy"
    np.save(surface, synthetic_surface("dense_asphalt", 0.3, 0.02, 1e-3, seed=2).heights)
    return pl.DataFrame({"path": [str(line), str(surface)], "run_id": ["line", "surface"],
                         "format": [None, "surface"], "dx": [None, 1e-3], "dy": [None, 1e-3],
                         "pavement": ["dense_asphalt"] * 2, "device": ["laser"] * 2})


def test_surface_runs_carry_none_of_the_line_pilots_estimates(tmp_path: Path) -> None:
    out = tmp_path / "out"
    summary = process(mixed_manifest(tmp_path), out, OPTIONS, quiet=True)
    assert summary.failed == 0
    runs = pl.read_parquet(out / "runs.parquet")
    bands = pl.read_parquet(out / "bands.parquet").filter(pl.col("reported"))
    line, surface = (runs.filter(pl.col("run_id") == rid) for rid in ("line", "surface"))
    # the line run has the pilot's numbers (so this test can fail) ...
    assert all(line[c][0] is not None for c in PLAN_RUN_COLUMNS)
    assert bands.filter(pl.col("run_id") == "line")["level_error_db"].null_count() == 0
    # ... the surface run none, in any of its rows, line-model rows included
    assert all(surface[c][0] is None for c in PLAN_RUN_COLUMNS)
    surface_bands = bands.filter(pl.col("run_id") == "surface")
    assert set(surface_bands["model"]) == {"line", "areal"}
    assert surface_bands["level_error_db"].null_count() == surface_bands.height > 0
    # the settings it really used: its own spacing, the job's tolerance
    assert surface["dx_used"][0] == 1e-3 and line["dx_used"][0] != 1e-3
    assert surface["tol_used"][0] == line["tol_used"][0]


def test_a_pilot_that_fails_is_recorded_and_warned_about(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def failing(*args, **kwargs):
        raise ValueError("deliberate pilot failure 17")

    monkeypatch.setattr(plan_module, "choose_setting", failing)
    with pytest.warns(ErrorBudgetWarning, match="laser / dense_asphalt.*deliberate pilot failure 17"):
        process(mixed_manifest(tmp_path), tmp_path / "out", OPTIONS, quiet=True)
    plan = json.loads((tmp_path / "out" / "parameters.json").read_text())["plan"]
    assert plan["failed_pilots"] == {"laser / dense_asphalt": "ValueError: deliberate pilot failure 17"}
