"""The job's plan (its error-budget pilot of line runs) is stated only where it applies: surface
runs carry their own areal pilot's estimates, none of the line pilot's; a pilot that could not run
is recorded, not dropped."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from roadtex.archive import ProcessingOptions, process
from roadtex.archive import planning as plan_module
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


def test_surface_runs_carry_their_own_estimates_not_the_line_pilots(tmp_path: Path) -> None:
    out = tmp_path / "out"
    summary = process(mixed_manifest(tmp_path), out, OPTIONS, quiet=True)
    assert summary.failed == 0
    runs = pl.read_parquet(out / "runs.parquet")
    bands = pl.read_parquet(out / "bands.parquet").filter(pl.col("reported"))
    line, surface = (runs.filter(pl.col("run_id") == rid) for rid in ("line", "surface"))
    # the line run has the pilot's numbers ...
    assert all(line[c][0] is not None for c in PLAN_RUN_COLUMNS)
    line_errors = bands.filter(pl.col("run_id") == "line").group_by("band").agg(pl.col("level_error_db").first())
    assert line_errors["level_error_db"].null_count() == 0
    # ... the surface run its own areal pilot's (runs/surface/level_errors.parquet), per model and
    # band, in every row, line-model rows included
    own = pl.read_parquet(out / "runs" / "surface" / "level_errors.parquet")
    assert set(own["model"]) == {"line", "areal"} and own["level_error_db"].null_count() == 0
    surface_bands = bands.filter(pl.col("run_id") == "surface")
    joined = surface_bands.join(own, on=["model", "band"], how="left", suffix="_own")
    assert joined["level_error_db_own"].null_count() == 0
    np.testing.assert_array_equal(joined["level_error_db"].to_numpy(), joined["level_error_db_own"].to_numpy())
    shared = own.filter(pl.col("model") == "line").join(line_errors, on="band", suffix="_pilot")
    assert shared.height > 0 and (shared["level_error_db"] != shared["level_error_db_pilot"]).any()
    assert surface["worst_level_error_db"][0] == own.filter(pl.col("in_budget"))["level_error_db"].max()
    assert surface["within_budget"][0] == (surface["worst_level_error_db"][0] <= OPTIONS.error_budget_db)
    assert surface["speedup"][0] == own["speedup"][0] != line["speedup"][0]
    assert surface["time_saved_fraction"][0] == pytest.approx(1 - 1 / own["speedup"][0], rel=1e-12)
    # the settings it really used: its own spacing, the job's tolerance
    assert surface["dx_used"][0] == 1e-3 and line["dx_used"][0] != 1e-3
    assert surface["tol_used"][0] == line["tol_used"][0]


def test_without_a_budget_surface_runs_have_no_estimate(tmp_path: Path) -> None:
    out = tmp_path / "out"
    options = ProcessingOptions(youngs_moduli=(2e6, 1e7), segment_length=0.128, tol=1e-8, error_budget_db=None)
    assert process(mixed_manifest(tmp_path), out, options, quiet=True).failed == 0
    assert not (out / "runs" / "surface" / "level_errors.parquet").exists()
    runs = pl.read_parquet(out / "runs.parquet")
    assert all(runs[c].null_count() == runs.height for c in PLAN_RUN_COLUMNS)
    assert pl.read_parquet(out / "bands.parquet")["level_error_db"].null_count() > 0
    assert pl.read_parquet(out / "bands.parquet")["level_error_db"].drop_nulls().len() == 0


def test_a_pilot_that_fails_is_recorded_and_warned_about(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def failing(*args, **kwargs):
        raise ValueError("deliberate pilot failure 17")

    monkeypatch.setattr(plan_module, "choose_setting", failing)
    with pytest.warns(ErrorBudgetWarning, match="laser / dense_asphalt.*deliberate pilot failure 17"):
        process(mixed_manifest(tmp_path), tmp_path / "out", OPTIONS, quiet=True)
    plan = json.loads((tmp_path / "out" / "parameters.json").read_text())["plan"]
    assert plan["failed_pilots"] == {"laser / dense_asphalt @ 0.5 mm": "ValueError: deliberate pilot failure 17"}
    line = pl.read_parquet(tmp_path / "out" / "runs.parquet").filter(pl.col("run_id") == "line").row(0, named=True)
    assert line["worst_level_error_db"] is None and line["error_source"] == "no pilot could run: no error estimate"


def test_a_sampled_run_that_cannot_be_read_is_recorded_and_replaced(tmp_path: Path) -> None:
    """The pilot samples runs spread over a group; an unreadable one is named in parameters.json
    with why, and another run of the group takes its place (three runs are still read)."""
    paths = [write_profile(synthetic_pavement("dense_asphalt", 0.4, 5e-4, seed=s), tmp_path / f"r{s}.csv")
             for s in range(4)]
    paths[0].write_text("not a profile at all\n")
    manifest = pl.DataFrame({"path": [str(p) for p in paths], "run_id": [f"r{s}" for s in range(4)],
                             "pavement": ["dense_asphalt"] * 4, "device": ["laser"] * 4})
    out = tmp_path / "out"
    summary = process(manifest, out, OPTIONS, quiet=True)
    assert summary.failed == 1
    plan = json.loads((out / "parameters.json").read_text())["plan"]
    assert set(plan["unread_runs"]) == {"r0"}
    assert plan["unread_runs"]["r0"].startswith("ProfileFormatError: r0.csv:")
    assert sorted(plan["groups"]["laser / dense_asphalt @ 0.5 mm"]) == ["r1", "r2", "r3"]


def test_an_unreadable_pick_is_replaced_by_its_own_neighbour(tmp_path: Path) -> None:
    """The sample stays spread: of 10 runs, 3 are sampled (r0, r4, r9); r9 cannot be read, so r8,
    its nearest untried neighbour, takes its place (not r1, next to a readable pick)."""
    runs = []
    for s in range(10):
        path = write_profile(synthetic_pavement("dense_asphalt", 0.2, 5e-4, seed=s), tmp_path / f"r{s}.csv")
        runs.append({"path": str(path), "run_id": f"r{s}"})
    Path(runs[9]["path"]).write_text("garbage\n")
    unread: dict[str, str] = {}
    read = plan_module.readable(runs, OPTIONS, 3, unread)
    assert [run["run_id"] for run, _ in read] == ["r0", "r4", "r8"]
    assert list(unread) == ["r9"]
    # at most PLAN_READ_ATTEMPTS runs are tried for a sampled one
    for s in (8, 7, 6, 5):
        Path(runs[s]["path"]).write_text("garbage\n")
    unread = {}
    read = plan_module.readable(runs, OPTIONS, 3, unread)
    assert [run["run_id"] for run, _ in read] == ["r0", "r4"]
    assert len(unread) == plan_module.PLAN_READ_ATTEMPTS
