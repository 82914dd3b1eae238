"""The sampling statement in the job and the report (issue 33): bands.parquet's sampling columns,
runs.parquet's contact resolution, the optional correction, the report's section."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from roadtex.archive import ProcessingOptions, process
from roadtex.demo import write_synthetic_archive
from roadtex.report.document import build_report


@pytest.fixture(scope="module")
def coarse_job(tmp_path_factory) -> dict[str, Path]:
    """One synthetic 1 mm run (no real data at that sampling: the job's plumbing only), processed
    with and without the correction, and at a pressure the calibration does not cover."""
    folder = tmp_path_factory.mktemp("coarse")
    manifest = write_synthetic_archive(folder / "archive", kinds=("dense_asphalt",), runs_per_kind=1, run_length=2.0,
                                       dx=1e-3)
    outs = {}
    for name, extra in (("plain", {}), ("corrected", {"sampling_correction": True}), ("other_pressure", {"mean_pressure": 4e5})):
        options = ProcessingOptions(youngs_moduli=(2e6, 1e7), error_budget_db=None, refine=8, **extra)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            process(manifest, folder / name, options, quiet=True)
        outs[name] = folder / name
    outs["manifest"] = manifest
    return outs


def test_job_states_the_sampling_apart_from_the_numerical_error(coarse_job) -> None:
    bands = pl.read_parquet(coarse_job["plain"] / "bands.parquet")
    runs = pl.read_parquet(coarse_job["plain"] / "runs.parquet")
    stated = bands.filter(pl.col("sampling_run_uncertainty_db").is_not_null())
    assert set(stated["label"].to_list()) == {"40", "31.5", "25", "20", "16", "12.5", "10", "8", "6.3", "5", "4", "3.15", "2.5"}
    assert stated["sampling_correction_db"].null_count() == stated.height   # not corrected
    assert (stated["sampling_uncertainty_db"] >= stated["sampling_run_uncertainty_db"]).all()
    short = stated.filter((pl.col("label") == "2.5") & (pl.col("youngs_modulus") == 2e6))
    assert short["sampling_bias_db"][0] < -0.5   # the calibration's systematic 1 mm bias (-0.91 dB since 0.5.0)
    assert runs["sampling_dx"][0] == pytest.approx(1e-3)
    # 1 mm data do not resolve the 2.5 mm band for contact: the run states a longer wavelength, or
    # none (three calibration files cannot state any band of 1 mm data within 1 dB at every E)
    resolved = runs["contact_resolved_to"][0]
    assert resolved is None or resolved > 2.6e-3
    assert stated["sampling_note"].null_count() == stated.height
    unstated = bands.filter(pl.col("sampling_run_uncertainty_db").is_null())
    assert unstated.height == 0 or unstated["sampling_note"].str.contains("outside the calibrated ones").all()
    units = json.loads(pl.read_parquet_metadata(coarse_job["plain"] / "bands.parquet")["units"])
    assert units["sampling_run_uncertainty_db"] == "dB"
    assert json.loads(pl.read_parquet_metadata(coarse_job["plain"] / "runs.parquet")["units"])["contact_resolved_to"] == "m"


def test_correction_moves_only_the_enveloped_levels_by_what_it_states(coarse_job) -> None:
    keys = ["run_id", "segment", "youngs_modulus", "band"]
    plain = pl.read_parquet(coarse_job["plain"] / "bands.parquet").sort(keys)
    corrected = pl.read_parquet(coarse_job["corrected"] / "bands.parquet").sort(keys)
    shift = (plain["enveloped_level"] - corrected["enveloped_level"]).to_numpy()
    stated = corrected["sampling_correction_db"].fill_null(0.0).to_numpy()
    assert np.allclose(np.nan_to_num(shift), np.where(np.isnan(shift), 0.0, stated), atol=1e-9)
    assert np.abs(stated).max() > 0.5   # at 1 mm the short bands' bias is corrected
    assert plain["texture_level"].equals(corrected["texture_level"])
    assert plain["pressure_level"].equals(corrected["pressure_level"])
    short = corrected.filter((pl.col("label") == "2.5") & (pl.col("youngs_modulus") == 2e6))
    assert short["sampling_correction_db"][0] == pytest.approx(short["sampling_bias_db"][0])


def test_no_statement_outside_the_calibration(coarse_job) -> None:
    bands = pl.read_parquet(coarse_job["other_pressure"] / "bands.parquet")
    runs = pl.read_parquet(coarse_job["other_pressure"] / "runs.parquet")
    assert bands["sampling_run_uncertainty_db"].null_count() == bands.height
    # the reason calibration_applies gives is in every row (0.3.0: null figures without a word)
    assert set(bands["sampling_note"].to_list()) == {
        "no sampling statement: calibrated at a mean pressure of 0.2 MPa, not 0.4 MPa"}
    assert runs["contact_resolved_to"][0] is None and runs["sampling_dx"][0] is None


def test_report_section_tells_which_bands_the_profiler_resolves(coarse_job) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = build_report(coarse_job["plain"])
    text = report.html.read_text()
    section = text[text.index("What the sampling cannot tell"):]
    assert "resolved for contact" in section
    assert "down to" in section or "in no band: not even the longest calibrated band is within 1 dB" in section
    assert '<table class="sampling"' in section or 'class="sampling"' in section


def test_cli_flag_turns_the_correction_on(coarse_job, tmp_path: Path) -> None:
    from roadtex.cli import main

    out = tmp_path / "cli"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["process", str(coarse_job["manifest"]), "--out", str(out), "--quiet", "--error-budget", "off",
                     "--refine", "8", "--moduli", "2", "10", "--sampling-correction"]) == 0
    assert json.loads((out / "parameters.json").read_text())["options"]["sampling_correction"] is True
    corrected = pl.read_parquet(out / "bands.parquet")["sampling_correction_db"]
    assert corrected.null_count() < corrected.len() and corrected.abs().max() > 0.5
