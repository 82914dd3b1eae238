"""Texture and pressure band spectra (roadtex.spectra) against analytic references.

References: the rms of a sine (A / sqrt 2), Parseval (band powers add to the variance), Westergaard's
full-contact pressure, ordinary least squares (numpy.polyfit), and the band arithmetic of ISO 13473-4.
"""

from __future__ import annotations

import math

import numpy as np
import polars as pl
import pytest

from roadtex import contact, reference, spectra
from roadtex.profiles.synthetic import self_affine_profile

ISO_THIRD_OCTAVE_LABELS = ["500", "400", "315", "250", "200", "160", "125", "100", "80", "63", "50", "40", "31.5",
                           "25", "20", "16", "12.5", "10", "8", "6.3", "5", "4", "3.15", "2.5", "2", "1.6", "1.25",
                           "1", "0.8", "0.63", "0.5", "0.4"]
ISO_OCTAVE_LABELS = ["500", "250", "125", "63", "31.5", "16", "8", "4", "2", "1", "0.5"]


def sine(n: int, dx: float, wavelength: float, amplitude: float, phase: float = 0.3) -> np.ndarray:
    return amplitude * np.sin(2.0 * np.pi * np.arange(n) * dx / wavelength + phase)


def level_of(table: pl.DataFrame, label: str) -> float:
    return table.filter(pl.col("label") == label)["level_db"].item()


def analytic_level(amplitude: float, reference: float = 1e-6) -> float:
    return 20.0 * math.log10(amplitude / math.sqrt(2.0) / reference)


# ---------------------------------------------------------------------------------------------- bands

def test_band_table_follows_iso_13473_4():
    """Centres 1000/10^(n/10) mm, the nominal labels of the standard, contiguous edges, octave = 3 thirds."""
    thirds = spectra.band_table(1e-4, 1.0)
    assert thirds["label"].to_list() == ISO_THIRD_OCTAVE_LABELS
    n = thirds["band"].to_numpy()
    np.testing.assert_allclose(thirds["centre_wavelength"].to_numpy() * 1e3, 1000.0 / 10.0 ** (n / 10.0), rtol=1e-14)
    # Each band's long edge is the next longer band's short edge: no gap, no overlap.
    np.testing.assert_allclose(thirds["upper_wavelength"][1:], thirds["lower_wavelength"][:-1], rtol=1e-14)
    # Bandwidth of a one-third octave (base 10): edges at 10^(+-1/20) of the centre.
    np.testing.assert_allclose(thirds["upper_wavelength"] / thirds["lower_wavelength"], 10.0 ** 0.1, rtol=1e-14)
    # Nominal values stay within 2 % of the exact centres.
    np.testing.assert_allclose(thirds["nominal_wavelength"], thirds["centre_wavelength"], rtol=0.02)

    octaves = spectra.band_table(1e-4, 1.0, "octave")
    assert octaves["label"].to_list() == ISO_OCTAVE_LABELS
    by_band = {b: row for b, row in zip(thirds["band"], thirds.iter_rows(named=True))}
    for row in octaves.iter_rows(named=True):
        if row["band"] - 1 in by_band:
            assert row["upper_wavelength"] == pytest.approx(by_band[row["band"] - 1]["upper_wavelength"], rel=1e-14)
        assert row["lower_wavelength"] == pytest.approx(by_band[row["band"] + 1]["lower_wavelength"], rel=1e-14)


def test_bands_at_the_sampling_limit():
    """dx = 1 mm: the 2.5 mm band (centre 2.51 mm >= 2.5 dx) is reported, the 2 mm band is not."""
    table = spectra.band_table(1e-3, 1.0)
    row = {r["label"]: r for r in table.iter_rows(named=True)}
    assert row["2.5"]["reported"] and row["2.5"]["reason"] is None
    assert not row["2"]["reported"] and "sampling" in row["2"]["reason"]
    # A sine at the shortest reported band is measured exactly (periodic, 400 whole periods).
    z = sine(1000, 1e-3, 2.5e-3, 2e-4)
    assert level_of(spectra.third_octave_levels(z, 1e-3, periodic=True), "2.5") == pytest.approx(
        analytic_level(2e-4), abs=1e-9)


def test_bands_at_the_evaluation_length_limit():
    """L = 96 mm: 8 mm needs 12 x 7.94 = 95.3 mm and is reported; 10 mm needs 120 mm and is not."""
    dx = 1e-3
    table = spectra.band_table(dx, 96 * dx)
    row = {r["label"]: r for r in table.iter_rows(named=True)}
    assert row["8"]["reported"] and row["8"]["lines"] >= 3
    assert not row["10"]["reported"] and "evaluation length" in row["10"]["reason"]
    assert not spectra.band_table(dx, 95 * dx).filter(pl.col("label") == "8")["reported"].item()
    # The longest reported band measures a sine of 12 whole periods exactly.
    z = sine(96, dx, 8e-3, 1e-4)
    assert level_of(spectra.third_octave_levels(z, dx, periodic=True), "8") == pytest.approx(
        analytic_level(1e-4), abs=1e-9)


def test_octave_reported_only_when_its_three_third_octaves_are():
    for dx, length in [(1e-3, 1.0), (1e-3, 96e-3), (5e-5, 0.2048), (2e-4, 0.05)]:
        thirds = spectra.band_table(dx, length)
        reported = dict(zip(thirds["band"], thirds["reported"]))
        for band, ok in zip(*spectra.band_table(dx, length, "octave")[["band", "reported"]]):
            assert ok == all(reported.get(b, False) for b in (band - 1, band, band + 1)) or (
                band == 3 and not ok), (dx, length, band)


def test_profile_shorter_than_the_longest_band():
    """A 50 mm profile: the long bands hold no DFT line (NaN) and are flagged; nothing raises."""
    dx = 1e-4
    z = self_affine_profile(500, 500 * dx, seed=3)
    table = spectra.third_octave_levels(z, dx)
    long_bands = table.filter(pl.col("lower_wavelength") > 500 * dx)
    assert long_bands.height > 0 and (long_bands["lines"] == 0).all()
    assert long_bands["level_db"].is_nan().all()
    assert not long_bands["reported"].any()
    assert long_bands["reason"].str.contains("evaluation length").all()
    reported = table.filter(pl.col("reported"))
    assert (12 * reported["centre_wavelength"] <= 500 * dx).all() and reported["level_db"].is_finite().all()


def test_profile_too_short_for_any_band_is_all_flagged():
    table = spectra.third_octave_levels(np.arange(8.0) * 1e-5, 1e-3)
    assert table.height == 32 and not table["reported"].any()


# ---------------------------------------------------------------------------------------------- levels

@pytest.mark.parametrize("periodic", [True, False])
def test_sine_of_8_mm_and_0_1_mm_gives_36_99_db(periodic):
    """The issue's check value: 20 lg(0.1e-3 / sqrt 2 / 1e-6) = 36.99 dB in the 8 mm band."""
    dx = 1e-4
    table = spectra.third_octave_levels(sine(4000, dx, 8e-3, 1e-4), dx, periodic=periodic)
    assert level_of(table, "8") == pytest.approx(36.99, abs=0.005)
    assert level_of(table, "8") == pytest.approx(analytic_level(1e-4), abs=1e-6)
    # Nothing else: every other band is at least 150 dB down for the exact periodic DFT. Slope
    # suppression of a measured profile takes a small ramp out of the sine (the least-squares line of
    # 50 periods), whose power lands in the long bands 40 dB down.
    others = table.filter((pl.col("label") != "8") & (pl.col("lines") > 0))["level_db"]
    assert (others < 36.99 - (150 if periodic else 40)).all()


def test_sine_with_a_fractional_number_of_periods_needs_the_window():
    """A measured profile does not repeat: the Hann window keeps the sine in its band to 0.02 dB."""
    dx = 1e-4
    z = sine(4003, dx, 8e-3, 1e-4) + 3e-3 + 0.01 * np.arange(4003) * dx  # offset and slope as measured
    windowed = spectra.third_octave_levels(z, dx)
    assert level_of(windowed, "8") == pytest.approx(36.99, abs=0.02)
    assert level_of(windowed, "4") < 36.99 - 60  # little leakage an octave away
    rectangular = spectra.third_octave_levels(z, dx, window="rectangular")
    assert level_of(rectangular, "4") > level_of(windowed, "4") + 20  # leakage the window removes


def test_several_sines_each_in_its_band():
    dx = 5e-5
    n = 8192
    length = n * dx
    amplitudes = {"16": 3e-4, "4": 1e-4, "1": 2e-5}
    z = np.zeros(n)
    for label, amplitude in amplitudes.items():
        periods = round(length / (float(label) * 1e-3))  # whole periods: periodic
        z += sine(n, dx, length / periods, amplitude, phase=periods)
    table = spectra.third_octave_levels(z, dx, periodic=True)
    for label, amplitude in amplitudes.items():
        assert level_of(table, label) == pytest.approx(analytic_level(amplitude), abs=1e-9)


def test_reference_scales_the_level():
    z = sine(1000, 1e-4, 5e-3, 1e-4)
    base = level_of(spectra.third_octave_levels(z, 1e-4, periodic=True), "5")
    other = level_of(spectra.third_octave_levels(z, 1e-4, periodic=True, reference=1e-5), "5")
    assert base - other == pytest.approx(20.0, abs=1e-12)


@pytest.mark.parametrize("seed", [1, 2])
def test_parseval_band_powers_add_up_to_the_variance(seed):
    """All the profile's power lies between 400 mm and 0.4 mm: band powers sum to its variance."""
    n, dx = 4096, 1e-4  # lines from 410 mm down; cutoff_fraction 0.25 keeps power above 0.8 mm
    z = self_affine_profile(n, n * dx, hurst=0.7, rms_slope=0.2, cutoff_fraction=0.25, seed=seed)
    periodic = spectra.third_octave_levels(z, dx, periodic=True)
    assert np.nansum(periodic["mean_square"].to_numpy()) == pytest.approx(np.var(z), rel=1e-12)


def test_parseval_with_the_hann_window():
    """Windowed and energy-corrected, band powers keep the variance of broadband texture.

    Random texture with equal power from 20 mm to 0.8 mm (lines 20 to 512 of 4,096 points at 0.1 mm).
    Exactly: the band powers add up to the variance of the detrended, windowed profile divided by the
    window's mean square (Parseval for the windowed signal; a missing energy correction would be off by
    a factor 8/3). On average: that estimate is the profile's variance; one profile scatters by about
    9 % (the window weights the middle), so 20 are averaged. Longer wavelengths are left out on
    purpose: the window moves a sixth of the power of the first line into k = 0, which no band holds,
    so the longest wavelengths of a measured profile are underestimated (and the standard's length
    limit leaves them unreported).
    """
    n, dx, count = 4096, 1e-4, 20
    rng = np.random.default_rng(2)
    spectrum = np.zeros((count, n // 2 + 1), complex)
    spectrum[:, 20:513] = rng.normal(size=(count, 493)) + 1j * rng.normal(size=(count, 493))
    profiles = 1e-4 * np.fft.irfft(spectrum, n, axis=1) + 1e-3 * rng.normal(size=(count, 1))
    result = spectra.band_levels(profiles, dx)
    band_power = np.nansum(result.mean_square, axis=1)
    hann = 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(n) / n)
    x = np.arange(n)
    for z, total in zip(profiles, band_power):
        windowed = (z - np.polyval(np.polyfit(x, z, 1), x)) * hann
        assert total == pytest.approx(np.var(windowed) / np.mean(hann**2), rel=1e-9)
    assert np.mean(band_power / np.var(profiles, axis=1)) == pytest.approx(1.0, abs=0.06)


@pytest.mark.parametrize("periodic", [True, False])
def test_octave_total_is_the_sum_of_its_three_third_octaves(periodic):
    n, dx = 4096, 1e-4
    z = self_affine_profile(n, n * dx, hurst=0.8, rms_slope=0.15, cutoff_fraction=0.5, seed=7)
    thirds = spectra.third_octave_levels(z, dx, periodic=periodic)
    octaves = spectra.octave_levels(z, dx, periodic=periodic)
    power = dict(zip(thirds["band"], np.nan_to_num(thirds["mean_square"].to_numpy())))
    checked = 0
    for band, mean_square in zip(octaves["band"], octaves["mean_square"]):
        if band - 1 in power and np.isfinite(mean_square):
            assert mean_square == pytest.approx(power[band - 1] + power[band] + power[band + 1], rel=1e-12)
            checked += 1
    assert checked >= 8


def test_band_levels_is_vectorised_over_rows():
    dx, n = 1e-4, 2048
    amplitudes = np.array([1e-5, 1e-4, 5e-4])
    rows = amplitudes[:, None] * np.sin(2 * np.pi * np.arange(n)[None, :] * dx / (n * dx / 64))
    result = spectra.band_levels(rows, dx, periodic=True)
    wavelength = n * dx / 64  # 3.2 mm
    column = int(np.flatnonzero((result.bands["lower_wavelength"] <= wavelength).to_numpy()
                                & (result.bands["upper_wavelength"] > wavelength).to_numpy())[0])
    np.testing.assert_allclose(result.levels[:, column], [analytic_level(a) for a in amplitudes], atol=1e-9)
    assert result.levels.shape == result.mean_square.shape == (3, result.bands.height)
    frame = result.to_frame(reported_only=True)
    assert frame["signal"].unique().sort().to_list() == [0, 1, 2] and frame["reported"].all()


def test_pressure_levels_of_westergaard_full_contact():
    """Full contact on A cos(2 pi x / 8 mm): p = P + p* cos(...), p* = pi E* A / lambda (Westergaard)."""
    wavelength, amplitude, periods, points_per_period = 8e-3, 1e-5, 12, 80
    dx = wavelength / points_per_period
    n = periods * points_per_period
    z = amplitude * np.cos(2 * np.pi * np.arange(n) * dx / wavelength)
    youngs, mean_pressure = 2.5e6, 2e5
    e_star = youngs / (1 - 0.5**2)
    p_star = reference.westergaard_full_contact_pressure(amplitude, wavelength, e_star)
    assert mean_pressure > p_star  # full contact
    result = contact(z, dx, youngs_modulus=youngs, mean_pressure=mean_pressure, tol=1e-12)
    table = spectra.pressure_levels(result.pressure, dx)
    assert spectra.REFERENCE_PRESSURE == 1.0
    # Element averaging lowers the amplitude by sinc(pi dx / lambda), 2.6e-4 here: well inside 0.01 dB.
    assert level_of(table, "8") == pytest.approx(20 * math.log10(p_star / math.sqrt(2)), abs=0.01)


# ---------------------------------------------------------------------------------------------- helpers

def test_time_frequency():
    assert spectra.time_frequency(8e-3, 80.0) == pytest.approx(80 / 3.6 / 8e-3, rel=1e-15)
    np.testing.assert_allclose(spectra.time_frequency(np.array([0.1, 0.01]), 36.0), [100.0, 1000.0])
    table = spectra.with_time_frequency(spectra.band_table(1e-4, 0.5), 80.0)
    eight = table.filter(pl.col("label") == "8").row(0, named=True)
    assert eight["lower_frequency"] < 80 / 3.6 / 8e-3 < eight["upper_frequency"]
    np.testing.assert_allclose(table["upper_frequency"] / table["lower_frequency"], 10 ** 0.1, rtol=1e-14)
    with pytest.raises(ValueError, match="speed_kmh must be a positive"):
        spectra.time_frequency(8e-3, 0.0)
    with pytest.raises(ValueError, match="wavelength_m must be positive"):
        spectra.time_frequency([8e-3, -1.0], 80.0)


def test_level_differences_per_band():
    """Halving a profile lowers every band by 20 lg 2 = 6.02 dB; E is carried as a key of the enveloped side."""
    dx = 1e-4
    z = self_affine_profile(2048, 2048 * dx, seed=11)
    original = spectra.third_octave_levels(z, dx, periodic=True).with_columns(pl.lit("A").alias("site"))
    enveloped = pl.concat([
        spectra.third_octave_levels(factor * z, dx, periodic=True).with_columns(
            pl.lit("A").alias("site"), pl.lit(modulus).alias("youngs_modulus"))
        for factor, modulus in [(0.5, 1e6), (0.25, 1e7)]])
    diff = spectra.level_differences(enveloped, original).filter(pl.col("reported"))
    expected = {1e6: 20 * math.log10(0.5), 1e7: 20 * math.log10(0.25)}
    for modulus, value in expected.items():
        np.testing.assert_allclose(diff.filter(pl.col("youngs_modulus") == modulus)["level_difference_db"], value,
                                   atol=1e-9)
    with pytest.raises(ValueError, match="more than one row"):
        spectra.level_differences(enveloped, pl.concat([original, original]))


def test_band_regressions_against_least_squares():
    rng = np.random.default_rng(5)
    rows = []
    truth = {}
    for band in (18, 21, 24):
        for modulus in (1e6, 5e6):
            slope, intercept = rng.uniform(0.5, 2.0), rng.uniform(40, 80)
            x = rng.uniform(20, 50, 9)
            y = intercept + slope * x + rng.normal(0, 1.0, x.size)
            truth[band, modulus] = (x, y)
            rows += [dict(band=band, youngs_modulus=modulus, texture_level=a, pressure_level=b) for a, b in zip(x, y)]
    # Rows the fit must ignore: -inf texture level (a band without power) and NaN.
    rows += [dict(band=18, youngs_modulus=1e6, texture_level=-np.inf, pressure_level=50.0),
             dict(band=21, youngs_modulus=5e6, texture_level=30.0, pressure_level=np.nan)]
    fits = spectra.band_regressions(pl.DataFrame(rows))
    assert fits.height == 6
    for fit in fits.iter_rows(named=True):
        x, y = truth[fit["band"], fit["youngs_modulus"]]
        slope, intercept = np.polyfit(x, y, 1)
        assert fit["slope"] == pytest.approx(slope, rel=1e-10)
        assert fit["intercept"] == pytest.approx(intercept, rel=1e-10)
        assert fit["r2"] == pytest.approx(np.corrcoef(x, y)[0, 1] ** 2, rel=1e-10)
        assert fit["n"] == 9


# ---------------------------------------------------------------------------------------------- bad input

def good(n: int = 64) -> np.ndarray:
    return 1e-4 * np.sin(np.arange(n) * 0.3)


def with_value(value: float, index: int = 5) -> np.ndarray:
    z = good()
    z[index] = value
    return z


BAD_INPUT = {
    "NaN": (lambda: spectra.third_octave_levels(with_value(np.nan), 1e-4),
            r"heights contains a non-finite value \(NaN\) at index 5"),
    "inf": (lambda: spectra.octave_levels(with_value(np.inf, 7), 1e-4), r"heights .*non-finite.*inf.*index 7"),
    "NaN in a row": (lambda: spectra.band_levels(np.stack([good(), with_value(np.nan, 3)]), 1e-4),
                     r"values row 1 contains a non-finite value \(NaN\) at index 3"),
    "NaN pressure": (lambda: spectra.pressure_levels(with_value(np.nan), 1e-4), r"pressure contains.*NaN"),
    "too short": (lambda: spectra.third_octave_levels(np.zeros(7), 1e-4), r"7 points.*at least 8"),
    "empty": (lambda: spectra.third_octave_levels([], 1e-4), r"heights is empty"),
    "2-D heights": (lambda: spectra.third_octave_levels(np.zeros((2, 64)), 1e-4), r"heights must be a 1-D array"),
    "1-D values": (lambda: spectra.band_levels(good(), 1e-4), r"values must be a 2-D array"),
    "text": (lambda: spectra.third_octave_levels(["a"] * 10, 1e-4), r"heights must be numeric"),
    "dx zero": (lambda: spectra.third_octave_levels(good(), 0.0), r"dx must be a positive finite"),
    "dx negative": (lambda: spectra.band_levels(good()[None], -1e-4), r"dx must be a positive finite"),
    "dx NaN": (lambda: spectra.third_octave_levels(good(), float("nan")), r"dx must be a positive finite"),
    "reference zero": (lambda: spectra.third_octave_levels(good(), 1e-4, reference=0.0),
                       r"reference must be a positive"),
    "kind": (lambda: spectra.band_levels(good()[None], 1e-4, kind="sixth"), r"kind must be 'third_octave' or 'octave'"),
    "window": (lambda: spectra.third_octave_levels(good(), 1e-4, window="hamming"), r"window must be 'hann'"),
    "detrend": (lambda: spectra.third_octave_levels(good(), 1e-4, detrend="quadratic"), r"detrend must be"),
    "window on periodic": (lambda: spectra.third_octave_levels(good(), 1e-4, periodic=True, window="hann"),
                           r"window and detrend apply only to periodic=False"),
    "band table length": (lambda: spectra.band_table(1e-3, 5e-3), r"holds 5 points.*at least 8"),
    "regression column": (lambda: spectra.band_regressions(pl.DataFrame({"band": [1]})), r"lacks the columns"),
}


@pytest.mark.parametrize("case", list(BAD_INPUT))
def test_bad_input_raises_a_clear_value_error(case):
    call, message = BAD_INPUT[case]
    with pytest.raises(ValueError, match=message):
        call()


def test_every_reported_third_octave_holds_at_least_two_dft_lines() -> None:
    """At the evaluation-length limit (12 centre wavelengths) a third octave is 2.77 line spacings
    wide: two lines at the least, as the module documents, never one or none."""
    fewest = min(int(spectra.band_table(1e-3, n * 1e-3).filter(pl.col("reported"))["lines"].min())
                 for n in range(90, 400))
    assert fewest == 2


def test_the_filter_method_warns_on_millimetres_and_leaves_lineless_bands_empty() -> None:
    """method="filter" keeps the DFT method's promises: heights in mm warn, and a band holding no
    DFT line of the segment gets NaN, not its filter skirts' share of the neighbours."""
    from roadtex.errors import ImplausibleTextureWarning

    z = self_affine_profile(1000, 0.1, hurst=0.8, rms_slope=0.2, seed=3)
    with pytest.warns(ImplausibleTextureWarning):
        spectra.band_levels(z[None, :] * 1e3, 1e-4, method="filter")
    levels = spectra.band_levels(z[None, :], 1e-4, method="filter", periodic=True)
    empty = levels.bands["lines"].to_numpy() == 0
    assert empty.any() and np.isnan(levels.levels[0, empty]).all()
    assert np.isfinite(levels.levels[0, ~empty & levels.bands["reported"].to_numpy()]).all()


@pytest.mark.parametrize(("points", "dx"), [(4000, 0.125e-3), (500, 1e-3), (999, 0.5e-3), (1000, 0.5e-3)])
def test_the_bands_hold_every_line_between_their_edges_and_no_other(points: int, dx: float) -> None:
    # A model grid has many lines past the shortest band (0.4 mm), which no band holds and which are
    # not turned into powers; every line between the table's outer edges is in exactly one band: the
    # band powers add up to the one-sided line powers between those edges (Nyquist line counted once),
    # computed here line by line from numpy's FFT
    rng = np.random.default_rng(points)
    signal = rng.normal(size=(3, points)) * 1e-4
    levels = spectra.band_levels(signal, dx, periodic=True)
    bands = levels.bands["band"].to_numpy()
    k = np.arange(1, points // 2 + 1)
    wavenumber = k / (points * dx)
    inside = (wavenumber >= 10.0 ** ((bands.min() - 0.5) / 10.0)) & (wavenumber < 10.0 ** ((bands.max() + 0.5) / 10.0))
    weight = np.where((points % 2 == 0) & (k == points // 2), 1.0, 2.0) / points**2
    line_power = np.abs(np.fft.rfft(signal, axis=1)[:, 1:]) ** 2 * weight
    expected = line_power[:, inside].sum(axis=1)
    np.testing.assert_allclose(np.nansum(levels.mean_square, axis=1), expected, rtol=1e-12)
    assert inside.sum() == levels.bands["lines"].sum()
    if dx < 0.2e-3:   # the case of a model grid: lines past the shortest band exist (none of them counts)
        assert (wavenumber >= 10.0 ** ((bands.max() + 0.5) / 10.0)).sum() > points // 8
