"""The report's section "What the sampling cannot tell" (issue 33): per sampling interval of the
runs, what their readings cannot tell of the enveloped levels (bands.parquet ``sampling_*``
columns, from :mod:`roadtex.budget.sampling`) and down to which wavelength each run's contact levels
are resolved (runs.parquet ``contact_resolved_to``). Apart from the numerical error (the section
before it). Reads only what the job wrote; a results folder from before these columns, or a job
whose settings the calibration does not cover, gets a sentence saying so.
"""

from __future__ import annotations

import html
from typing import Callable

import polars as pl

from roadtex.budget.sampling import RESOLVED_DB
from roadtex.report.data import MM, Results, plain

COLUMNS = ("sampling_bias_db", "sampling_uncertainty_db", "sampling_run_uncertainty_db")


def sampling_table(results: Results) -> pl.DataFrame:
    """One row per (sampling interval, calibrated band): the bias of the enveloped levels (range over
    the moduli, dB), what one segment's level and a run's mean level cannot tell (the largest over
    moduli and runs, dB), and whether every run of that sampling resolves the band for contact.
    Empty when the job stated nothing."""
    bands, runs = results.bands, results.runs
    if not set(COLUMNS) <= set(bands.columns) or "sampling_dx" not in runs.columns:
        return pl.DataFrame()
    rows = (bands.filter(pl.col("sampling_run_uncertainty_db").is_not_null())
            .join(runs.select("run_id", "sampling_dx"), on="run_id", how="inner"))
    if rows.height == 0:
        return pl.DataFrame()
    table = (rows.group_by("sampling_dx", "band").agg(
        pl.col("label").first(), pl.col("sampling_bias_db").min().alias("low"), pl.col("sampling_bias_db").max().alias("high"),
        # corrections are biases, mostly negative: what was subtracted is any non-zero one, not the largest
        pl.col("sampling_correction_db").filter(pl.col("sampling_correction_db") != 0).min().alias("corrected_low"),
        pl.col("sampling_correction_db").filter(pl.col("sampling_correction_db") != 0).max().alias("corrected_high"),
        (pl.col("sampling_correction_db").fill_null(0.0) == 0).any().alias("uncorrected_rows"),
        pl.col("sampling_uncertainty_db").max().alias("segment"), pl.col("sampling_run_uncertainty_db").max().alias("run"))
        .sort("sampling_dx", "band"))
    return pl.DataFrame({
        "sampling (mm)": [plain(v * MM, 3) for v in table["sampling_dx"]],
        "band (mm)": table["label"],
        "bias (dB, over E)": [plain(lo, 2) if abs(hi - lo) < 0.005 else f"{plain(lo, 2)} to {plain(hi, 2)}"
                              for lo, hi in zip(table["low"], table["high"])],
        "corrected (dB)": [corrected(lo, hi, some_not) for lo, hi, some_not
                           in zip(table["corrected_low"], table["corrected_high"], table["uncorrected_rows"])],
        "one segment: +/- (dB)": [plain(v, 2) for v in table["segment"]],
        "run mean: +/- (dB)": [plain(v, 2) for v in table["run"]],
        "resolved for contact": ["yes" if v <= RESOLVED_DB else "no" for v in table["run"]],
    })


def corrected(low: float | None, high: float | None, some_not: bool) -> str:
    """The table's cell for what ``--sampling-correction`` subtracted from a band's enveloped levels
    (the range of the non-zero corrections, dB; ``some_not``: some moduli or runs uncorrected)."""
    if low is None or high is None:
        return "no"
    said = plain(low, 2) if abs(high - low) < 0.005 else f"{plain(low, 2)} to {plain(high, 2)}"
    return f"yes: {said}" + (" (not at every E or run)" if some_not else "")


def sampling_section(results: Results, html_table: Callable[..., str]) -> str:
    """The section's HTML: a paragraph with the runs' resolution, and the table (:func:`sampling_table`,
    drawn by the document's ``html_table``)."""
    table = sampling_table(results)
    if table.height == 0:
        notes = (results.bands["sampling_note"].drop_nulls().unique().sort().to_list()
                 if "sampling_note" in results.bands.columns else [])
        if notes:   # the job said why (bands.parquet sampling_note)
            return "<p>No sampling statement: " + html.escape("; ".join(n.removeprefix("no sampling statement: ")
                                                                          for n in notes[:3])) + ".</p>"
        return ("<p>No sampling statement: the job's results have none (a roadtex before it, surface runs only, or "
                "settings the calibration does not cover: it holds for 0.5 m segments, P = 0.2 MPa, third-octave "
                "DFT levels and samplings up to 1 mm).</p>")
    runs = results.runs.filter(pl.col("sampling_dx").is_not_null())
    resolved = runs.group_by("contact_resolved_to").agg(pl.len().alias("n")).sort("contact_resolved_to", nulls_last=True)
    said = "; ".join(
        (f"{n} run(s) down to {plain(v * MM, 3)} mm" if v is not None
         else f"{n} run(s) in no band: not even the longest calibrated band is within {plain(RESOLVED_DB)} dB")
        for v, n in resolved.iter_rows())
    return ("<p>What the data's sampling cannot tell of the enveloped levels, apart from the numerical error above: "
            "the contact model converged on the readings still sees only the road they describe. Calibrated on the "
            "three CAPTIF profiles (0.0375 mm, one chip-seal pavement) averaged to coarser samplings "
            "(roadtex.budget.sampling; bands.parquet sampling_bias_db, sampling_uncertainty_db for one segment, "
            "sampling_run_uncertainty_db for a run's mean; each a half-width holding the 0.0375 mm data's level "
            f"in about 95 % of cases). A band is resolved for contact when its run-mean figure is at most "
            f"{plain(RESOLVED_DB)} dB (runs.parquet contact_resolved_to): {html.escape(said)}.</p>"
            + html_table(table, classes="sampling"))
