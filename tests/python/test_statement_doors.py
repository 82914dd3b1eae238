"""Issue 38, the sampling statement's, the sections' and the report's doors: each case a fallback
that changed or dropped a number without a word, or a refusal that was missing."""

from __future__ import annotations

from pathlib import Path

import polars as pl

from roadtex.report.data import Results
from roadtex.report.sampling_section import sampling_table


def results_with(bands: pl.DataFrame, runs: pl.DataFrame) -> Results:
    empty = pl.DataFrame()
    return Results(root=Path("."), segments=empty, bands=bands, runs=runs, errors=empty, examples=empty,
                   edge_effect=empty, parameters={})


def test_report_says_corrected_for_a_band_corrected_by_a_negative_bias() -> None:
    # the 1 mm data's 2.5 mm band is corrected by about -0.91 dB at 2 MPa, not at 10 MPa: the table
    # took the largest correction (0) and said "no"
    bands = pl.DataFrame({
        "run_id": ["a"] * 4, "band": [26, 26, 14, 14], "label": ["2.5", "2.5", "40", "40"],
        "youngs_modulus": [2e6, 1e7] * 2, "sampling_bias_db": [-0.91, -0.3, 0.1, 0.1],
        "sampling_correction_db": [-0.91, 0.0, 0.0, 0.0], "sampling_uncertainty_db": [1.0, 1.0, 0.5, 0.5],
        "sampling_run_uncertainty_db": [0.6, 0.6, 0.3, 0.3]})
    runs = pl.DataFrame({"run_id": ["a"], "sampling_dx": [1e-3]})
    table = sampling_table(results_with(bands, runs))
    cells = dict(zip(table["band (mm)"], table["corrected (dB)"]))
    assert cells["2.5"].startswith("yes: -0.91") and "not at every E" in cells["2.5"]
    assert cells["40"] == "no"
    uncorrected = sampling_table(results_with(bands.with_columns(pl.lit(None, dtype=pl.Float64)
                                                                 .alias("sampling_correction_db")), runs))
    assert set(uncorrected["corrected (dB)"]) == {"no"}
