"""Issue 38, the sampling statement's, the sections' and the report's doors: each case a fallback
that changed or dropped a number without a word, or a refusal that was missing."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from roadtex.archive.sections import section_band_table, section_index, section_table
from roadtex.budget.sampling import contact_resolved_to, run_statement, sampling_statement, shipped_calibration
from roadtex.errors import InvalidInputError
from roadtex.profiles import Profile, mpd
from roadtex.profiles.pavements import synthetic_pavement
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


@pytest.mark.parametrize("moduli, match", [
    ([float("nan")], "positive, finite"), ([0.0], "positive, finite"), ([-2e6], "positive, finite"),
    ([], "at least one modulus"), ([2e6, float("inf")], "positive, finite"), (["soft"], "moduli in Pa")])
def test_sampling_statement_refuses_moduli_that_are_not(moduli, match) -> None:
    # 0.3.0 answered NaN rows (NaN), another modulus' figures (0, -2 MPa: the nearest calibrated)
    # or an error from polars' concat of nothing (an empty list)
    with pytest.raises(InvalidInputError, match=match):
        sampling_statement(1e-3, moduli, 8)


def test_sampling_statement_refuses_an_unknown_level_and_a_bad_spot() -> None:
    with pytest.raises(InvalidInputError, match="level must be 'enveloped' or 'pressure'"):
        sampling_statement(1e-3, [2e6], 8, level="texture")   # 0.3.0: no rows, as if coarser than calibrated
    for width in (float("nan"), -0.2e-3, 2e-3):
        with pytest.raises(InvalidInputError, match="width"):
            sampling_statement(1e-3, [2e6], 8, width=width)
    with pytest.raises(InvalidInputError, match="n_segments"):
        sampling_statement(1e-3, [2e6], float("nan"))


def test_a_modulus_listed_twice_is_stated_once() -> None:
    # the job joins the statement on (modulus, band): duplicated statement rows doubled bands.parquet's
    once = sampling_statement(1e-3, [2e6], 8)
    assert sampling_statement(1e-3, [2e6, 2e6], 8).equals(once)


CENTRES = {b: 10.0 ** (-b / 10.0) for b in range(11, 29)}   # 80 mm to 1.6 mm: bands outside 2.5-40 mm too


@pytest.mark.parametrize("settings, reason", [
    ({"mean_pressure": 4e5}, "mean pressure of 0.2 MPa, not 0.4 MPa"),
    ({"band_kind": "octave"}, "third-octave DFT"), ({"band_method": "filter"}, "third-octave DFT"),
    ({"segment_length": 0.256}, "0.5 m segments, not 0.256 m")])
def test_run_statement_says_why_it_states_nothing_and_that_a_correction_was_not_made(settings, reason) -> None:
    arguments = {"file_dx": 1e-3, "dx_used": 1e-3, "length": 4.0, "segment_length": 0.5, "n_segments": 8,
                 "youngs_moduli": [2e6, 1e7], "mean_pressure": 2e5, "band_kind": "third_octave", "band_method": "dft",
                 "centre_wavelengths": CENTRES} | settings
    for correct in (False, True):
        rows, sampling, resolved = run_statement(**arguments, correct=correct)
        assert rows.height == 2 * len(CENTRES) and sampling is None and resolved is None
        assert rows["sampling_run_uncertainty_db"].null_count() == rows.height
        notes = set(rows["sampling_note"].to_list())
        assert len(notes) == 1 and reason in notes.pop()
        said = rows["sampling_note"][0]
        assert ("--sampling-correction asked for, not applied" in said) == correct


def test_run_statement_notes_the_bands_and_samplings_it_cannot_state() -> None:
    arguments = {"length": 4.0, "segment_length": 0.5, "n_segments": 8, "youngs_moduli": [2e6],
                 "mean_pressure": 2e5, "band_kind": "third_octave", "band_method": "dft", "centre_wavelengths": CENTRES}
    rows, sampling, _ = run_statement(1e-3, 1e-3, **arguments, correct=True)
    assert sampling == pytest.approx(1e-3)
    stated = rows.filter(pl.col("sampling_run_uncertainty_db").is_not_null())
    assert sorted(stated["band"].to_list()) == list(range(14, 27)) and stated["sampling_note"].null_count() == 13
    outside = rows.filter(pl.col("sampling_run_uncertainty_db").is_null())
    assert sorted(outside["band"].to_list()) == [11, 12, 13, 27, 28]
    assert all("outside the calibrated ones (bands 14 to 26)" in n and "not applied" in n for n in outside["sampling_note"])
    coarse, sampling, resolved = run_statement(2e-3, 2e-3, **arguments)
    assert sampling is None and resolved is None and coarse["sampling_run_uncertainty_db"].null_count() == coarse.height
    assert "sampled every 2 mm, coarser than the calibration's 1 mm" in coarse["sampling_note"][0]


def test_report_says_why_the_job_stated_nothing() -> None:
    from roadtex.report.sampling_section import sampling_section

    note = "no sampling statement: calibrated on third-octave DFT band levels (--sampling-correction asked for, not applied)"
    bands = pl.DataFrame({"run_id": ["a"], "band": [26], "label": ["2.5"], "youngs_modulus": [2e6],
                          "sampling_bias_db": [None], "sampling_correction_db": [None], "sampling_uncertainty_db": [None],
                          "sampling_run_uncertainty_db": [None], "sampling_note": [note]},
                         schema_overrides={c: pl.Float64 for c in ("sampling_bias_db", "sampling_correction_db",
                                                                   "sampling_uncertainty_db", "sampling_run_uncertainty_db")})
    runs = pl.DataFrame({"run_id": ["a"], "sampling_dx": [None]}, schema_overrides={"sampling_dx": pl.Float64})
    text = sampling_section(results_with(bands, runs), lambda *a, **k: "")
    assert "third-octave DFT band levels (--sampling-correction asked for, not applied)" in text


def calibration_rows(bands_at: dict[tuple[float, float], list[int]]) -> pl.DataFrame:
    """A calibration table whose bias is the band number / 100 dB at every (dx, E) of ``bands_at``."""
    rows = [{"level": "enveloped", "dx": dx, "width": dx, "youngs_modulus": e, "band": b, "label": str(b),
             "centre_wavelength": 10.0 ** (-b / 10.0), "bias_db": b / 100.0, "within_sd_db": 0.1,
             "between_sd_db": 0.05, "bias_se_db": 0.05, "files": 3, "segments": 12, "between_floored": False}
            for (dx, e), bands in bands_at.items() for b in bands]
    return pl.DataFrame(rows, schema=shipped_calibration().schema)


def test_interpolated_matches_bands_by_number_and_refuses_bands_it_cannot_match() -> None:
    # a caller's table listing its bands in another order at one modulus: 0.3.0 blended row i of
    # one modulus with row i of the other (sorted, so a missing band shifted every row after it)
    same = calibration_rows({(1e-3, 2e6): [24, 25, 26], (1e-3, 1e7): [26, 25, 24]})
    between = sampling_statement(1e-3, [4e6], 8, table=same)
    assert dict(zip(between["band"], between["sampling_bias_db"])) == pytest.approx({24: 0.24, 25: 0.25, 26: 0.26})
    shifted = calibration_rows({(1e-3, 2e6): [24, 25, 26], (1e-3, 1e7): [25, 26, 27]})
    with pytest.raises(InvalidInputError, match=r"bands differ between E = 2e\+06 and 1e\+07 Pa.*\[24, 27\]"):
        sampling_statement(1e-3, [4e6], 8, table=shifted)
    samplings = calibration_rows({(0.5e-3, 2e6): [24, 25], (1e-3, 2e6): [25, 26]})
    with pytest.raises(InvalidInputError, match=r"bands differ between dx = 0.0005 and 0.001 m"):
        sampling_statement(0.7e-3, [2e6], 8, table=samplings)
    twice = calibration_rows({(1e-3, 2e6): [24, 24, 25]})
    with pytest.raises(InvalidInputError, match="band 24 twice"):
        sampling_statement(1e-3, [2e6], 8, table=twice)


def test_sections_chainage_runs_from_the_first_reading() -> None:
    # a 1 mm file from 0 m: 0.3.0 gave -0.0005-9.9995 m, 9.9995-19.9995 m (the baselines' edge)
    profile = synthetic_pavement("dense_asphalt", 20.05, 1e-3, seed=3)
    table = section_table("r", mpd(profile), 10.0)
    assert table["start"].to_list() == pytest.approx([0.0, 10.0], abs=1e-12)
    assert table["end"].to_list() == pytest.approx([10.0, 20.0], abs=1e-12)
    assert table["baselines"].to_list() == [100, 100]
    moved = section_table("r", mpd(Profile.from_heights(profile.heights, 1e-3, start=123.4)), 10.0)
    assert moved["start"].to_list() == pytest.approx([123.4, 133.4], abs=1e-9)


def test_section_index_refuses_positions_outside_the_sections() -> None:
    # 0.3.0 clipped a start 5 m past the run into its last section, one before it into the first
    assert section_index(np.array([0.0, 9.99, 10.0, 19.5]), 0.0, 10.0, 2).tolist() == [0, 0, 1, 1]
    assert section_index(np.array([-0.0004]), 0.0, 10.0, 2, tolerance=0.0005).tolist() == [0]
    for wrong in (25.0, -3.0, float("nan")):
        with pytest.raises(InvalidInputError, match="outside the run's 2 section"):
            section_index(np.array([1.0, wrong]), 0.0, 10.0, 2)


@pytest.mark.parametrize("length", [1e-6, 0.05, float("nan"), float("inf"), -10.0])
def test_a_section_shorter_than_the_mpd_baseline_is_refused(length) -> None:
    # 0.3.0 wrote a row per micrometre (4,000,000 rows for 4 m), none holding an MPD
    with pytest.raises(InvalidInputError, match="at least the 100 mm MPD baseline"):
        section_table("r", mpd(synthetic_pavement("dense_asphalt", 1.0, 1e-3, seed=3)), length)


def test_parameters_json_is_strict_json_with_non_finite_numbers_named(tmp_path: Path) -> None:
    # 0.3.0 wrote Infinity (worst_level_error_db of a run whose pilot picked a filled segment), which
    # strict JSON readers refuse
    from roadtex.archive.store import write_json

    write_json(tmp_path / "parameters.json", {"plan": {"worst_level_error_db": float("inf"),
                                                       "band_error_db": {"26": float("nan"), "25": 0.5},
                                                       "bounds": (float("-inf"), np.float64("inf"))}})

    def refuse(constant: str) -> None:
        raise ValueError(f"not strict JSON: {constant}")

    written = json.loads((tmp_path / "parameters.json").read_text(), parse_constant=refuse)
    assert written["plan"] == {"worst_level_error_db": None, "band_error_db": {"26": None, "25": 0.5},
                               "bounds": [None, None]}
    assert written["non_finite"] == {"plan.worst_level_error_db": "inf", "plan.band_error_db.26": "nan",
                                     "plan.bounds[0]": "-inf", "plan.bounds[1]": "inf"}


# The hunt's cases (issue 38: the doors tried as an attacker would); each failed on the code before.

@pytest.mark.parametrize("change, match", [
    (lambda t: t.drop("bias_se_db"), r"lacks the column\(s\) \['bias_se_db'\]"),
    (lambda t: t.drop("level"), r"lacks the column\(s\) \['level'\]"),
    (lambda t: t.with_columns(pl.lit(float("nan")).alias("bias_db")), "not a finite number"),
    (lambda t: t.with_columns(pl.lit(-1.0).alias("within_sd_db")), "negative scatter"),
    (lambda t: t.with_columns(pl.lit(1).alias("files")), "at least 2 files"),
    (lambda t: "calibration.csv", "must be a calibration")])
def test_a_caller_table_is_checked_at_the_door(change, match) -> None:
    # before: polars' ColumnNotFoundError, NaN rows, a statement from a negative scatter or one file
    with pytest.raises(InvalidInputError, match=match):
        sampling_statement(1e-3, [2e6], 3, table=change(shipped_calibration()))


@pytest.mark.parametrize("arguments", [
    {"dx": True}, {"n_segments": "3"}, {"n_segments": True}, {"youngs_moduli": [True]}, {"width": 0.3e-3}])
def test_numbers_that_are_not_and_an_uncalibrated_spot_are_refused(arguments) -> None:
    # before: True read as 1 m or 1 Pa, "3" as 3 segments, a 0.3 mm spot answered with no rows
    given = {"dx": 1e-3, "youngs_moduli": [2e6], "n_segments": 3} | arguments
    with pytest.raises(InvalidInputError):
        sampling_statement(**given)


def test_a_modulus_outside_the_calibration_says_whose_figures_it_has() -> None:
    # the nearest calibrated modulus' figures, said in the row (before: without a word)
    stated = sampling_statement(1e-3, [2e7, 2e6], 3)
    outside = stated.filter(pl.col("youngs_modulus") == 2e7)
    assert set(outside["sampling_note"]) == {"E = 20 MPa is outside the calibrated 1 to 10 MPa: the figures of 10 MPa"}
    assert stated.filter(pl.col("youngs_modulus") == 2e6)["sampling_note"].null_count() == 13
    rows, _, _ = run_statement(1e-3, 1e-3, 4.0, 0.5, 8, [2e7], 2e5, "third_octave", "dft", CENTRES)
    assert rows.filter(pl.col("band") == 26)["sampling_note"][0].startswith("E = 20 MPa is outside")


def test_settings_that_are_not_numbers_are_not_the_calibrated_ones() -> None:
    # NaN compared as "not beyond the tolerance": a NaN pressure or segment length was calibrated
    for pressure, length in ((float("nan"), 0.5), (2e5, float("nan"))):
        rows, sampling, _ = run_statement(1e-3, 1e-3, 4.0, length, 8, [2e6], pressure, "third_octave", "dft", CENTRES)
        assert sampling is None and rows["sampling_run_uncertainty_db"].null_count() == rows.height


def test_contact_resolution_refuses_a_band_without_a_centre() -> None:
    statement = pl.DataFrame({"youngs_modulus": [2e6] * 2, "band": [14, 15], "sampling_run_uncertainty_db": [0.3, 0.4]})
    with pytest.raises(InvalidInputError, match=r"no centre for band\(s\) \[15\]"):   # before: KeyError
        contact_resolved_to(statement, {14: 0.04})


def test_section_bands_refuse_rows_of_a_segment_without_a_start() -> None:
    # before: a row of section null in section_bands.parquet
    sections = section_table("r", mpd(synthetic_pavement("dense_asphalt", 2.05, 1e-3, seed=3)), 1.0)
    bands = pl.DataFrame({"segment": [5], "run_id": ["r"], "youngs_modulus": [2e6], "band": [20], "label": ["10"],
                          "centre_wavelength": [0.01], "reported": [True], "texture_level": [1.0],
                          "enveloped_level": [1.0], "pressure_level": [1.0]})
    with pytest.raises(InvalidInputError, match=r"segment\(s\) \[5\] have no segment start"):
        section_band_table(sections, bands, np.array([0.2]), 1.0)
    with pytest.raises(InvalidInputError, match="section_length"):
        section_table("r", mpd(synthetic_pavement("dense_asphalt", 1.0, 1e-3, seed=3)), True)
