"""The report's von Meier (seed figure 2.1) and valley penetration (4.3) figures are drawn from the
job's own tables (von_meier.parquet, penetration.parquet): the report computes no envelope."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex.comparisons.figures as comparison_figures
import roadtex.models.envelopes as envelopes_module
from roadtex.archive import ProcessingOptions, process
from roadtex.demo import write_synthetic_archive
from roadtex.report import build_report

OPTIONS = ProcessingOptions(youngs_moduli=(1e6, 5e6), segment_length=0.25, tol=1e-6)


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("comparisons")
    manifest = write_synthetic_archive(folder / "archive", kinds=("dense_asphalt", "porous_asphalt"),
                                       runs_per_kind=1, run_length=0.6)
    process(manifest, folder / "results", OPTIONS, quiet=True)
    return folder / "results"


def test_the_job_writes_the_comparison_tables_with_their_units(results: Path) -> None:
    examples = pl.read_parquet(results / "examples.parquet")
    von_meier = pl.read_parquet(results / "von_meier.parquet")
    penetration = pl.read_parquet(results / "penetration.parquet")
    assert set(von_meier["run_id"]) == set(penetration["run_id"]) == set(examples["run_id"])
    assert sorted(von_meier["d_star"].unique()) == [13.5, 27.0, 54.0, 108.0]
    assert set(penetration["youngs_modulus"]) == set(OPTIONS.youngs_moduli)
    assert (penetration["mean_pressure"] == OPTIONS.mean_pressure).all()
    for (run_id,), rows in examples.group_by("run_id"):
        first = rows.filter(pl.col("youngs_modulus") == rows["youngs_modulus"].min()).sort("position")
        for (d_star,), envelope in von_meier.filter(pl.col("run_id") == run_id).group_by("d_star"):
            envelope = envelope.sort("index")
            # the envelope of the segment the job solved: its heights, and never below them
            assert np.array_equal(envelope["height"].to_numpy(), first["height"].to_numpy())
            assert np.all(envelope["envelope"].to_numpy() >= envelope["height"].to_numpy() - 1e-15)
            # the von Meier bound: curvature at most 2 d* wherever the envelope bridges
            e = envelope["envelope"].to_numpy()
            dx = float(first["dx"][0])
            assert np.max(np.diff(e, 2)) / dx**2 <= 2 * d_star * (1 + 1e-6) + 1e-9
    units = {name: json.loads(pl.read_parquet_metadata(results / f"{name}.parquet")["units"])
             for name in ("von_meier", "penetration")}
    assert units["von_meier"]["d_star"] == "1/m" and units["von_meier"]["envelope"] == "m"
    assert units["penetration"]["inrets_penetration"] == "m" and units["penetration"]["youngs_modulus"] == "Pa"
    parameters = json.loads((results / "parameters.json").read_text())
    assert parameters["units"]["penetration"]["von_meier_penetration"] == "m"


def test_the_report_draws_both_figures_without_computing_an_envelope(results: Path,
                                                                       monkeypatch: pytest.MonkeyPatch,
                                                                       tmp_path: Path) -> None:
    def forbidden(*args, **kwargs):
        raise AssertionError("the report computed an envelope")

    for module, name in ((comparison_figures, "von_meier_envelopes"), (comparison_figures, "penetration_table"),
                         (comparison_figures, "example_comparisons"), (comparison_figures, "von_meier"),
                         (comparison_figures, "valleys"), (envelopes_module, "von_meier")):
        monkeypatch.setattr(module, name, forbidden)
    report = build_report(results, out_dir=tmp_path / "report")
    assert "von_meier" in report.figures and "valley_penetration" in report.figures
    text = report.html.read_text(encoding="utf-8")
    assert 'id="von_meier"' in text and 'id="valley_penetration"' in text
