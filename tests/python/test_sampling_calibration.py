"""What a coarse profiler cannot see (issue 33): the calibration on the CAPTIF files, held out one
file at a time, the statement's rules, and its columns in the job and the report."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from roadtex.budget.sampling import (
    REFERENCE_DX,
    contact_resolved_to,
    sampling_statement,
    shipped_calibration,
    summarise,
)
from roadtex.budget.sampling_calibration import file_differences, leave_one_out, periodic_average
from roadtex.errors import InvalidInputError


def test_periodic_average_is_the_mean_of_the_linear_road_over_each_window() -> None:
    rng = np.random.default_rng(3)
    heights = rng.normal(size=(2, 400)) * 1e-3
    dx = 0.05e-3
    length = heights.shape[1] * dx
    # the road between readings is linear and periodic: integrate it numerically on a dense grid
    dense = np.linspace(0.0, 2 * length, 2 * 400 * 200, endpoint=False)
    wrapped = np.append(heights, heights[:, :1], axis=1)
    road = np.array([np.interp(dense % length, np.arange(401) * dx, row) for row in wrapped])
    for points, width in ((50, None), (50, 0.2e-3), (37, None)):
        w = length / points if width is None else width
        got = periodic_average(heights, dx, points, width)
        centres = np.arange(points) * length / points
        expected = np.array([[row[(np.abs(((dense - c + length / 2) % length) - length / 2) <= w / 2)].mean()
                              for c in centres] for row in road])
        assert got.shape == (2, points)
        assert np.allclose(got, expected, atol=2e-3 * np.abs(heights).max())


def test_periodic_average_damps_a_sine_by_its_window() -> None:
    n, dx, wavelength = 4000, 0.01e-3, 2.5e-3
    x = np.arange(n) * dx
    sine = np.sin(2 * np.pi * x / wavelength)[None, :]
    coarse = periodic_average(sine, dx, 40)     # 1 mm readings, 1 mm windows
    gain = np.abs(np.fft.rfft(coarse[0]))[int(round(n * dx / wavelength))] / 20
    assert gain == pytest.approx(np.sinc(1e-3 / wavelength), rel=1e-3)   # -2.4 dB at 2.5 mm


def test_periodic_average_refuses_a_window_it_cannot_take() -> None:
    with pytest.raises(InvalidInputError, match="window"):
        periodic_average(np.zeros((1, 100)), 1e-4, 4)


def toy_table(bias: float, within: float, between: float, se: float) -> pl.DataFrame:
    rows = []
    for dx in (0.5e-3, 1e-3):
        for e in (2e6, 1e7):
            rows.append({"level": "enveloped", "dx": dx, "width": dx, "youngs_modulus": e, "band": 26, "label": "2.5",
                         "centre_wavelength": 2.5e-3, "bias_db": bias * dx / 1e-3, "within_sd_db": within,
                         "between_sd_db": between, "bias_se_db": se, "files": 3, "segments": 12,
                         "between_floored": False})
    return pl.DataFrame(rows, schema=shipped_calibration().schema)


def test_run_uncertainty_falls_with_the_segments_to_what_the_calibration_knows() -> None:
    table = toy_table(-1.0, 2.0, 0.2, 0.2)
    single = sampling_statement(1e-3, [2e6], 1, table=table)
    values = [sampling_statement(1e-3, [2e6], n, table=table)["sampling_run_uncertainty_db"][0] for n in (1, 4, 16, 1e9)]
    assert values[0] == pytest.approx(single["sampling_uncertainty_db"][0])
    assert values[0] > values[1] > values[2] >= values[3]
    # the long-run limit: the bias, and the between-file scatter and the bias's own standard error
    # expanded by Student's t at 2 degrees of freedom (3 files; 4.53 at 95.45 %, JCGM 100 Table G.2)
    assert values[3] == pytest.approx(1.0 + 4.527 * math.hypot(0.2, 0.2), abs=2e-3)
    assert sampling_statement(1e-3, [2e6], math.inf, table=table)["sampling_run_uncertainty_db"][0] == pytest.approx(values[3])


def test_a_long_run_is_stated_with_the_bias_standard_error_corrected_or_not() -> None:
    # issue 38: a 10 km run at 1 mm (20,000 segments) was stated at |bias| + 2 x the between-file
    # scatter, which three files put at 0 in 158 of 728 rows: 0.33 dB where 2 standard errors of
    # the bias alone were 0.35 dB (2.5 mm... 6.3 mm bands at 10 MPa)
    table = shipped_calibration().filter((pl.col("level") == "enveloped") & (pl.col("dx") == 1e-3)
                                         & (pl.col("width") == 1e-3))
    moduli = sorted(set(table["youngs_modulus"].to_list()))
    for correct in (False, True):
        stated = sampling_statement(1e-3, moduli, 20_000, correct=correct).join(
            table.select("youngs_modulus", "band", "bias_se_db"), on=["youngs_modulus", "band"])
        assert stated.height == table.height
        residual = (stated["sampling_bias_db"] - stated["sampling_correction_db"].fill_null(0.0)).abs()
        floor = residual + 2 * stated["bias_se_db"]
        assert (stated["sampling_run_uncertainty_db"] >= floor).all(), stated.filter(
            stated["sampling_run_uncertainty_db"] < floor)
        assert (stated["sampling_uncertainty_db"] >= stated["sampling_run_uncertainty_db"] - 1e-12).all()


def test_the_between_file_variance_is_floored_and_says_so() -> None:
    # three files whose means agree better than their segments' noise predicts: the variance
    # estimate is negative; 0.3.0 clipped it to 0, claiming a long run converges to the bias
    rows = []
    for file, offset in (("a", 0.0), ("b", 0.01), ("c", -0.01)):
        for start, noise in enumerate((-0.4, 0.4, -0.4, 0.4)):
            rows.append({"file": file, "start": start * 0.5, "dx": 1e-3, "width": 1e-3, "youngs_modulus": 2e6,
                         "band": 26, "label": "2.5", "centre_wavelength": 2.5e-3, "enveloped_db": -1.0 + offset + noise,
                         "pressure_db": 0.0, "fine_enveloped": 60.0, "fine_pressure": 100.0})
    table = summarise(pl.DataFrame(rows))
    within = table["within_sd_db"][0]
    assert table["between_floored"][0]
    assert table["between_sd_db"][0] == pytest.approx(within / 2.0)   # within^2 x mean(1 / n), 4 segments a file
    spread = summarise(pl.DataFrame(rows).with_columns(
        pl.when(pl.col("file") == "b").then(pl.col("enveloped_db") + 3.0).otherwise(pl.col("enveloped_db"))))
    assert not spread["between_floored"][0] and spread["between_sd_db"][0] > within / 2.0


def test_correction_only_where_the_bias_is_systematic_and_material() -> None:
    big = sampling_statement(1e-3, [2e6], 4, table=toy_table(-1.0, 0.8, 0.2, 0.2), correct=True)
    assert big["sampling_correction_db"][0] == pytest.approx(-1.0)
    uncorrected = sampling_statement(1e-3, [2e6], 4, table=toy_table(-1.0, 0.8, 0.2, 0.2))
    assert uncorrected["sampling_correction_db"][0] is None
    assert big["sampling_run_uncertainty_db"][0] < uncorrected["sampling_run_uncertainty_db"][0]
    noisy = sampling_statement(1e-3, [2e6], 4, table=toy_table(-1.0, 0.8, 0.2, 0.6), correct=True)   # < 2 se
    small = sampling_statement(1e-3, [2e6], 4, table=toy_table(-0.3, 0.1, 0.0, 0.01), correct=True)  # < 0.5 dB
    assert noisy["sampling_correction_db"][0] == 0.0 and small["sampling_correction_db"][0] == 0.0


def test_statement_between_and_beyond_the_calibrated_samplings() -> None:
    table = toy_table(-1.0, 0.8, 0.2, 0.2)
    at = {dx: sampling_statement(dx, [2e6], 4, table=table)["sampling_bias_db"][0] for dx in (0.5e-3, 0.7e-3, 1e-3)}
    assert at[0.5e-3] == pytest.approx(-0.5) and at[1e-3] == pytest.approx(-1.0)
    assert -1.0 < at[0.7e-3] < -0.5
    fine = sampling_statement(REFERENCE_DX, [2e6], 4, table=table)
    assert fine["sampling_run_uncertainty_db"][0] == 0.0
    assert -0.5 < sampling_statement(0.2e-3, [2e6], 4, table=table)["sampling_bias_db"][0] < 0.0
    assert sampling_statement(1.5e-3, [2e6], 4, table=table).is_empty()
    # moduli between the calibrated ones, and outside them (the nearest)
    assert sampling_statement(1e-3, [5e6, 5e7], 4, table=table).height == 2


def test_contact_resolution_stops_at_the_first_unresolved_band_from_the_long_side() -> None:
    statement = pl.DataFrame({"youngs_modulus": [2e6] * 4 + [1e7] * 4, "band": [14, 15, 16, 17] * 2,
                              "sampling_run_uncertainty_db": [0.3, 0.5, 1.5, 0.4, 0.3, 0.6, 0.7, 0.2]})
    centres = {14: 40e-3, 15: 31.5e-3, 16: 25e-3, 17: 20e-3}
    assert contact_resolved_to(statement, centres) == 31.5e-3   # 25 mm fails at 2 MPa: 20 mm is not reached
    assert contact_resolved_to(statement, centres, threshold_db=2.0) == 20e-3
    assert contact_resolved_to(statement, centres, threshold_db=0.2) is None


def test_the_shipped_calibration_holds_the_samplings_and_the_one_millimetre_bias() -> None:
    table = shipped_calibration()
    samplings = set(table.filter(pl.col("dx") == pl.col("width"))["dx"].round(6).to_list())
    assert {0.00005, 0.0001, 0.00025, 0.0005, 0.001} <= samplings
    assert set(table["youngs_modulus"].to_list()) == {1e6, 2e6, 5e6, 1e7}
    short = table.filter((pl.col("level") == "enveloped") & (pl.col("dx") == 1e-3) & (pl.col("width") == 1e-3)
                         & (pl.col("label") == "2.5") & (pl.col("youngs_modulus") == 2e6))
    # the 1 mm data's systematic bias at 2.5 mm (issue 33: -1.2 dB; -1.41 on the linear road of 0.4,
    # -0.91 on the monotone cubic road since 0.5.0): clearly more than the 0.05 mm data's
    assert short["bias_db"][0] < -0.5


def test_leave_one_out_on_captif_covers_the_run_mean_difference(captif_dir: Path) -> None:
    """Calibrated on two CAPTIF files, tested on the third: the stated run-mean uncertainty covers the
    actual difference of the run's mean enveloped level (0.5 and 1 mm averages against the 0.0375 mm
    data) in at least 90 % of the band x E cases, for the run's own segments and at the long-run
    limit (all of the file's segments against the statement for infinitely many: 0.3.0 covered
    75 % there, with overlapping segments). A reduced set for the suite (non-overlapping segments,
    2 moduli); benches/sampling_calibration.py runs the full one."""
    files = sorted(captif_dir.glob("*.dat"))
    differences = pl.concat([file_differences(f, samplings=((0.5e-3, 0.5e-3), (1e-3, 1e-3)),
                                              youngs_moduli=(2e6, 1e7), step=0.5) for f in files])
    for correct in (False, True):
        for long_run in (False, True):
            result = leave_one_out(differences, correct=correct, long_run=long_run)
            assert result.height == 3 * 2 * 2 * 13
            assert result["covered"].mean() >= 0.9, (correct, long_run, result.filter(~pl.col("covered")))
            # a calibration of two files knows its bias and between-file scatter to 1 degree of
            # freedom (t = 14 at 95.45 %): wide, but not without bound
            ratio = (result["stated_db"] / result["actual_db"].abs()).median()
            assert ratio <= 15.0, (correct, ratio)
            assert result["segments_covered"].mean() >= 0.9   # single segments by the one-segment figure
