"""Surface runs' conditioning: gross outliers (drop-out codes) are removed as on line runs, counted
in runs.parquet (``outlier_fraction``) and warned about with the line runs' thresholds; the
plausibility check judges the heights without them; a clean surface is conditioned as before."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest

from roadtex.archive import ProcessingOptions, process, surface_run
from roadtex.archive.surface_run import compute_surface_run, condition_surface
from roadtex.errors import RunFailure
from roadtex.profiles.conditioning import WARN_DROPOUT_FRACTION
from roadtex.surfaces import synthetic_surface

DX = 0.5e-3
OPTIONS = ProcessingOptions(segment_length=0.2, youngs_moduli=(2e6, 5e6), tol=1e-8)


def surface_heights(seed: int = 4) -> np.ndarray:
    """A 0.2 m x 0.02 m surface at 0.5 mm: 40 rows x 400 columns."""
    return synthetic_surface("dense_asphalt", 0.2, 0.02, DX, seed=seed).heights.copy()


def with_block(heights: np.ndarray, value: float) -> np.ndarray:
    """``heights`` with a 3 mm x 3 mm block (6 x 6 readings) set to ``value`` (m), a drop-out code."""
    out = heights.copy()
    out[17:23, 197:203] = value
    return out


def save(tmp_path: Path, heights: np.ndarray, name: str = "s") -> dict:
    path = tmp_path / f"{name}.npy"
    np.save(path, heights)
    return {"path": str(path), "run_id": name, "format": "surface", "dx": DX, "dy": DX}


def test_a_drop_out_code_block_is_removed_counted_and_left_out_of_the_solved_surface(tmp_path: Path) -> None:
    heights = with_block(surface_heights(), -0.850)
    run = save(tmp_path, heights)
    manifest = pl.DataFrame({k: [v] for k, v in run.items() if k != "run_id"})
    summary = process(manifest, tmp_path / "out", OPTIONS, quiet=True)
    assert summary.failed == 0
    runs = pl.read_parquet(tmp_path / "out" / "runs.parquet")
    # the 36 readings of the block, and nothing else, are outliers
    assert runs["outlier_fraction"][0] * runs["points"][0] == pytest.approx(36)
    example = pl.read_parquet(tmp_path / "out" / "surface_examples.parquet")
    assert example["height"].min() > -0.1           # the solved tile no longer reaches -850 mm
    assert float(np.nanmin(heights)) == pytest.approx(-0.850)
    # 36 of 16000 readings: below every warning threshold
    assert runs["conditioning_warnings"][0] is None


def test_twenty_percent_drop_outs_are_warned_about_in_the_runs_row(tmp_path: Path) -> None:
    heights = surface_heights()
    rng = np.random.default_rng(7)
    heights[rng.random(heights.shape) < 0.20] = np.nan
    table = compute_surface_run(save(tmp_path, heights), OPTIONS)["run"]
    assert table["dropout_fraction"][0] == pytest.approx(0.20, abs=0.01)
    note = table["conditioning_warnings"][0]
    assert note is not None and "drop-outs" in note and f"{100 * WARN_DROPOUT_FRACTION:g} %" in note


def test_spikes_and_outliers_beyond_five_percent_are_warned_about(tmp_path: Path) -> None:
    heights = surface_heights()
    rng = np.random.default_rng(3)
    heights[rng.random(heights.shape) < 0.08] = -0.9     # a drop-out code on 8 % of the readings
    table = compute_surface_run(save(tmp_path, heights), OPTIONS)["run"]
    assert table["outlier_fraction"][0] == pytest.approx(0.08, abs=0.01)
    assert "spikes or outliers" in table["conditioning_warnings"][0]


def test_the_plausibility_check_judges_heights_without_the_outliers(tmp_path: Path) -> None:
    # a drop-out code of -5 m would make the surface's peak-to-valley 5 m, a "unit mistake"
    table = compute_surface_run(save(tmp_path, with_block(surface_heights(), -5.0)), OPTIONS)["run"]
    assert table["outlier_fraction"][0] > 0
    # heights in mm read as metres are still refused: nothing is an outlier of its own scale
    with pytest.raises(RunFailure, match="implausible"):
        compute_surface_run(save(tmp_path, surface_heights() * 1e3, "mm"), OPTIONS)


def test_a_clean_surface_is_conditioned_exactly_as_before(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from roadtex.surfaces.surface import Surface

    heights = surface_heights(seed=9)
    raw = Surface.from_heights(heights, DX)
    conditioned, summary, missing = condition_surface(raw, OPTIONS.spike_alpha)
    assert not missing.any()   # a clean surface: every sample read
    # the pipeline before outlier removal, from the surface's public steps
    before = raw.remove_spikes(OPTIONS.spike_alpha).fill_dropouts().remove_plane()
    assert np.array_equal(conditioned.heights, before.heights)
    assert summary.outlier_fraction == 0.0 and summary.warnings == ()
    run = save(tmp_path, heights)
    now = compute_surface_run(run, OPTIONS)
    monkeypatch.setattr(surface_run, "condition_surface",
                        lambda surface, alpha: (surface.remove_spikes(alpha).fill_dropouts().remove_plane(), summary, missing))
    old = compute_surface_run(run, OPTIONS)
    for name in ("segments", "bands", "surface_example"):
        assert now[name].equals(old[name]), name
    assert now["run"]["outlier_fraction"][0] == 0.0 and now["run"]["conditioning_warnings"][0] is None
