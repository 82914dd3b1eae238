"""The report on a job of line and surface runs (an adversarial hunt, 0.5.15): its octave table holds
the surface runs (each row's own three third octaves, never three lines' bands summed), and its
verdict on the budget is every run's, not the line pilots' alone."""

from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex.archive import ProcessingOptions, process
from roadtex.report.data import read_results
from roadtex.report.error_budget import budget_summary, job_verdict
from roadtex.report.spectra_figures import octave_table
from roadtex.surfaces import synthetic_surface


@pytest.fixture(scope="module")
def job(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("mixed")
    np.save(folder / "sa.npy", synthetic_surface("porous_asphalt", 0.4, 0.02, 1e-3, seed=2).heights)
    roadtex.write_profile(roadtex.synthetic_pavement("dense_asphalt", 1.0, 0.5e-3, seed=4), folder / "ln.csv")
    manifest = pl.DataFrame({"run_id": ["sa", "ln"], "path": [str(folder / "sa.npy"), str(folder / "ln.csv")],
                             "format": ["surface", None], "dx": [1e-3, None], "dy": [1e-3, None],
                             "pavement": ["PAC", "DAC"]})
    with pytest.warns(roadtex.errors.RoadtexWarning):
        process(manifest, folder / "out", ProcessingOptions(segment_length=0.2, youngs_moduli=(2e6, 5e6)), quiet=True)
    return folder / "out"


def test_the_octave_table_holds_surface_runs_from_each_row_s_own_bands(job: Path) -> None:
    results = read_results(job)
    table = octave_table(results)
    assert set(table["run_id"]) == {"sa", "ln"}
    # by hand: each row's (model, tile, line, E) three third octaves summed in power, the sums
    # energetically averaged over the rows where all three are reported
    bands = pl.read_parquet(job / "bands.parquet").filter(pl.col("reported") & (pl.col("run_id") == "sa"))
    octave, modulus = 21, 2e6   # 8 mm: bands 20, 21, 22
    parts = bands.filter(pl.col("band").is_in([20, 21, 22]) & (pl.col("youngs_modulus") == modulus))
    sums = []
    for _, rows in parts.group_by("model", "segment", "line"):
        if rows.height == 3:
            sums.append((10.0 ** (rows["texture_level"].to_numpy() / 10)).sum())
    assert len(sums) > 1
    expected = 10 * np.log10(np.mean(sums))
    row = table.filter((pl.col("run_id") == "sa") & (pl.col("band") == octave) & (pl.col("youngs_modulus") == modulus))
    assert row["texture_level"].item() == pytest.approx(expected, abs=1e-9)


def test_the_verdict_is_every_run_s(job: Path) -> None:
    results = read_results(job)
    runs = pl.read_parquet(job / "runs.parquet")
    within, worst = job_verdict(results)
    assert within == bool(runs["within_budget"].all())
    assert worst == pytest.approx(runs["worst_level_error_db"].max())
    # the surface run states more than the line run's pilot: the headline is the surface run's
    surface = runs.filter(pl.col("run_id") == "sa")["worst_level_error_db"].item()
    assert surface > results.plan["worst_error_db"] and worst == pytest.approx(surface)
    text = budget_summary(results)
    assert f"Within budget: {'yes' if within else 'no'}" in text
