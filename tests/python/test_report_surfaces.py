"""The report's 3D-surface part (issue 17): drawn only when the results hold areal rows; the
line-against-areal table agrees with the plane-strain case."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from roadtex.archive import ProcessingOptions, process
from roadtex.demo import write_synthetic_archive
from roadtex.profiles import synthetic_pavement
from roadtex.report import build_report
from roadtex.report.data import load_results
from roadtex.report.surface_figures import AGREEMENT_DB, agreement_table, line_minus_areal, surface_error_table

OPTIONS = ProcessingOptions(segment_length=0.2, youngs_moduli=(2e6, 5e6), tol=1e-8)


@pytest.fixture(scope="module")
def mixed_results(tmp_path_factory) -> Path:
    """Two line runs and two surface runs (one of them a line profile extruded across the road)."""
    root = tmp_path_factory.mktemp("mixed")
    manifest = write_synthetic_archive(root / "archive", kinds=("dense_asphalt",), runs_per_kind=2, run_length=0.6,
                                       surfaces_per_kind=1, surface_size=(0.4, 0.03))
    line = synthetic_pavement("porous_asphalt", 0.4, 1e-3, seed=9).heights[:400]
    np.save(root / "archive" / "extruded.npy", np.tile(line, (6, 1)))
    table = pl.read_csv(manifest)
    extra = pl.DataFrame({"path": ["extruded.npy"], "run_id": ["extruded"], "format": ["surface"], "dx": [1e-3],
                          "dy": [1e-3], "pavement": ["extruded"]})
    pl.concat([table, extra], how="diagonal_relaxed").write_csv(manifest)
    process(manifest, root / "results", OPTIONS, quiet=True)
    return root / "results"


def test_report_draws_surfaces_when_areal_rows(mixed_results: Path, tmp_path: Path) -> None:
    report = build_report(mixed_results, out_dir=tmp_path / "report")
    assert "surface_tiles" in report.figures and "line_vs_areal" in report.figures
    text = report.html.read_text(encoding="utf-8")
    assert f"within {AGREEMENT_DB:g} dB of the areal model" in text
    assert 'class="surfaces"' in text


def test_seed_figures_use_line_rows_only(mixed_results: Path) -> None:
    results = load_results(mixed_results)
    assert set(results.segments["model"]) == {"line"} and set(results.bands["model"]) == {"line"}
    assert results.surface_bands is not None and set(results.surface_bands["model"]) == {"line", "areal"}
    # the surface tables hold only the surface runs
    assert set(results.surface_bands["run_id"]) == {"dense_asphalt_surface_001", "extruded"}
    assert results.surface_examples is not None
    assert set(results.surface_examples["run_id"]) == {"dense_asphalt_surface_001", "extruded"}


def test_extruded_surface_agrees_in_every_band(mixed_results: Path) -> None:
    """Plane strain: on a surface that is a line profile extruded across the road, the line model
    and the areal model give the same envelope, so every band is within 0.5 dB (in fact ~0)."""
    results = load_results(mixed_results)
    differences = line_minus_areal(results).filter(pl.col("group") == "extruded")
    assert differences.height > 0 and differences["difference_db"].abs().max() < 1e-6
    table = agreement_table(results).filter(pl.col("pavement") == "extruded")
    assert table.height == 2
    assert set(table["bands beyond (mm)"]) == {"none"}
    # a real 3D surface is not plane strain: somewhere the models differ
    other = line_minus_areal(results).filter(pl.col("group") == "dense_asphalt")
    assert other["difference_db"].abs().max() > 1e-3


def test_line_only_results_build_without_surface_part(tmp_path: Path) -> None:
    manifest = write_synthetic_archive(tmp_path / "archive", kinds=("dense_asphalt",), runs_per_kind=1,
                                       run_length=0.6)
    process(manifest, tmp_path / "results", OPTIONS, quiet=True)
    results = load_results(tmp_path / "results")
    assert results.surface_bands is None
    report = build_report(tmp_path / "results", out_dir=tmp_path / "report")
    assert "surface_tiles" not in report.figures and "line_vs_areal" not in report.figures
    assert 'class="surfaces"' not in report.html.read_text(encoding="utf-8")


def test_report_states_the_surface_levels_numerical_error(mixed_results: Path, tmp_path: Path) -> None:
    """The surface part carries each surface run's own error estimates (its areal pilot's), the
    largest per pavement, band and model, as bands.parquet holds them."""
    results = load_results(mixed_results)
    table = surface_error_table(results)
    bands = pl.read_parquet(mixed_results / "bands.parquet").filter(
        pl.col("reported") & (pl.col("run_id") == "dense_asphalt_surface_001"))
    for model in ("line", "areal"):
        expected = bands.filter(pl.col("model") == model).group_by("label").agg(pl.col("level_error_db").max())
        shown = table.filter(pl.col("pavement") == "dense_asphalt").select("band (mm)", f"{model} model error (dB)")
        joined = expected.join(shown, left_on="label", right_on="band (mm)")
        assert joined.height == expected.height > 0
        np.testing.assert_array_equal(joined["level_error_db"].to_numpy(), joined[f"{model} model error (dB)"].to_numpy())
    text = build_report(mixed_results, out_dir=tmp_path / "report").html.read_text(encoding="utf-8")
    assert 'class="surface-errors"' in text and "not resolved by the data's sampling" in text


def test_a_job_of_surface_runs_only_has_a_report(tmp_path: Path) -> None:
    """No line run, so no example segment for the profile figures: the report leaves those out
    and draws the rest (it used to fail on the missing example)."""
    manifest = write_synthetic_archive(tmp_path / "archive", kinds=("dense_asphalt",), runs_per_kind=0,
                                       run_length=0.6, surfaces_per_kind=1, surface_size=(0.4, 0.03))
    summary = process(manifest, tmp_path / "results", OPTIONS, quiet=True)
    assert summary.failed == 0 and summary.surface_runs == summary.runs == 1
    assert " m of road; 1 surface run(s) at their own spacings in " in str(summary)
    report = build_report(tmp_path / "results", out_dir=tmp_path / "report")
    assert {"surface_tiles", "line_vs_areal", "texture_spectra"} <= set(report.figures)
    assert not {"envelopes", "pressures", "valley_penetration", "von_meier"} & set(report.figures)
    # the budget was on: the report says the surface runs carry their own estimates, not "budget off"
    text = report.html.read_text(encoding="utf-8")
    assert "No line-run pilot" in text and "error budget off" not in text
    plan = json.loads((tmp_path / "results" / "parameters.json").read_text())["plan"]
    assert plan["source"].startswith("no line run to plan for")


def test_surface_runs_over_budget_are_marked_apart_from_profile_runs(mixed_results: Path) -> None:
    """Issue 40: a pavement whose surface runs state errors over the budget in a band where its
    profile runs are within it gets that band marked apart (orange dots, "surface runs only"), not red;
    a band over the budget in a profile run stays red. The stated errors are set here so that each
    kind is over in one band of its own."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from roadtex.report.data import OVER_BUDGET_LABEL, SURFACE_OVER_BUDGET_LABEL
    from roadtex.report.spectra_figures import fig_pressure_spectra, fig_texture_spectra

    results = load_results(mixed_results)
    budget = results.options["error_budget_db"]
    surfaces = set(results.surface_bands["run_id"])
    bands = sorted(results.bands.filter(pl.col("pavement") == "dense_asphalt")["band"].unique()
                   if "pavement" in results.bands.columns else results.bands["band"].unique())
    surface_band, profile_band = bands[len(bands) // 2], bands[len(bands) // 2 + 1]
    is_surface = pl.col("run_id").is_in(pl.Series(sorted(surfaces)).implode())
    stated = (pl.when(is_surface & (pl.col("band") == surface_band)).then(5 * budget)
              .when(~is_surface & (pl.col("band") == profile_band)).then(5 * budget)
              .otherwise(budget / 10).alias("level_error_db"))
    results.bands = results.bands.with_columns(stated)

    fig = fig_texture_spectra(plt, results)
    try:
        panel = next(ax for ax in fig.axes if ax.get_title() == "dense_asphalt")
        marked = {gid: {round(p.get_x() + p.get_width() / 2) for p in panel.patches if p.get_gid() == gid}
                  for gid in ("over_budget", "over_budget_surfaces")}
        assert marked == {"over_budget": {profile_band}, "over_budget_surfaces": {surface_band}}
        entries = [t.get_text() for legend in fig.legends for t in legend.get_texts()]
        assert entries.count(OVER_BUDGET_LABEL) == 1 and entries.count(SURFACE_OVER_BUDGET_LABEL) == 1
        # the extruded pavement has no profile run: its surface's band is marked as a surface's
        extruded = next(ax for ax in fig.axes if ax.get_title() == "extruded")
        assert {p.get_gid() for p in extruded.patches if p.get_gid() and "over_budget" in p.get_gid()} \
            == {"over_budget_surfaces"}
    finally:
        plt.close(fig)
    fig = fig_pressure_spectra(plt, results)
    try:
        panel = next(ax for ax in fig.axes if ax.get_title() == "dense_asphalt")
        assert sum(p.get_gid() == "over_budget" for p in panel.patches) == 1
        assert sum(p.get_gid() == "over_budget_surfaces" for p in panel.patches) == 1
    finally:
        plt.close(fig)
