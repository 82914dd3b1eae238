"""roadtex.calibrate_modulus: recovering the E behind synthetic noise data.

Synthetic sites are self-affine profiles with different Hurst exponents, rms slopes and cut-offs, so
that the rubber envelops them differently. Their "measured" noise is made from the band levels of
the profiles enveloped at a known E (a different gain and offset per band, as real noise has) plus
0.5 dB of scatter. The calibration must find that E on its grid, inside its stated interval.
"""

from __future__ import annotations

import math

import numpy as np
import polars as pl
import pytest

from roadtex import contact, contact_many, spectra
from roadtex.profiles.synthetic import self_affine_profile
from roadtex.spectra import calibration
from roadtex.spectra.calibration import calibrate_modulus

POINTS, DX = 1024, 2e-4  # 204.8 mm segments: bands 16 mm to 0.5 mm reported
SEGMENTS = 2
MODULI = (1.0e6, 1.6e6, 2.5e6, 4.0e6, 6.3e6, 10.0e6)
MEAN_PRESSURE = 2e5
SCATTER_DB = 0.5


@pytest.fixture(scope="module")
def sites() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(1)
    profiles = {}
    for site in range(8):
        hurst, rms_slope, cutoff = rng.uniform(0.5, 0.9), rng.uniform(0.05, 0.4), rng.uniform(0.1, 0.4)
        profiles[f"site {site}"] = np.stack([
            self_affine_profile(POINTS, POINTS * DX, hurst=hurst, rms_slope=rms_slope, cutoff_fraction=cutoff,
                                seed=100 * site + k) for k in range(SEGMENTS)])
    return profiles


def synthetic_noise(sites: dict[str, np.ndarray], youngs_modulus: float, seed: int = 2,
                    scatter_db: float = SCATTER_DB, lines: dict[int, tuple[float, float]] | None = None) -> pl.DataFrame:
    """Noise levels (dB) = offset + gain x enveloped texture level at E, per band, plus scatter.
    ``lines``, when given, receives band -> (gain, offset)."""
    segments = np.concatenate(list(sites.values()))
    envelope = contact_many(segments, DX, youngs_modulus, MEAN_PRESSURE, tol=1e-8).envelope[:, 0, :]
    levels = spectra.band_levels(envelope, DX, periodic=True)
    energy_mean = levels.mean_square.reshape(len(sites), SEGMENTS, -1).mean(axis=1)
    texture = 10 * np.log10(energy_mean / spectra.REFERENCE_TEXTURE**2)
    rng = np.random.default_rng(seed)
    rows = []
    for column, (band, reported) in enumerate(zip(levels.bands["band"], levels.bands["reported"])):
        if not reported:
            continue
        gain, offset = rng.uniform(0.5, 1.5), rng.uniform(20.0, 50.0)
        if lines is not None:
            lines[int(band)] = (gain, offset)
        for row, site in enumerate(sites):
            rows.append(dict(site=site, band=band,
                             level_db=offset + gain * texture[row, column] + rng.normal(0.0, scatter_db)))
    return pl.DataFrame(rows)


@pytest.mark.parametrize("true_modulus", [2.5e6, 6.3e6])
def test_recovers_the_modulus_behind_the_noise(sites, true_modulus):
    noise = synthetic_noise(sites, true_modulus)
    result = calibrate_modulus(sites, DX, noise, moduli=MODULI, mean_pressure=MEAN_PRESSURE, n_bootstrap=500)
    assert result.best_modulus == true_modulus
    low, high = result.interval
    assert low <= true_modulus <= high
    assert not result.at_grid_edge
    scores = dict(zip(result.scores["youngs_modulus"], result.scores["bootstrap_share"]))
    assert scores[true_modulus] > 0.5
    assert result.scores["bootstrap_share"].sum() == pytest.approx(1.0)
    # The mean correlation rises towards the true E and falls after it (checked on the grid ends).
    by_modulus = dict(zip(result.scores["youngs_modulus"], result.scores["mean_correlation"]))
    assert by_modulus[true_modulus] > by_modulus[MODULI[0]] and by_modulus[true_modulus] > by_modulus[MODULI[-1]]


def test_more_scatter_widens_the_interval_which_still_holds_the_truth(sites):
    """With 2 dB of scatter the sites no longer pin E to one grid value; the interval says so."""
    true_modulus = 2.5e6
    precise = calibrate_modulus(sites, DX, synthetic_noise(sites, true_modulus, seed=4), moduli=MODULI,
                                n_bootstrap=500)
    noisy = calibrate_modulus(sites, DX, synthetic_noise(sites, true_modulus, seed=4, scatter_db=2.0),
                              moduli=MODULI, n_bootstrap=500)
    assert noisy.interval[0] <= true_modulus <= noisy.interval[1]
    assert noisy.interval[1] / noisy.interval[0] > precise.interval[1] / precise.interval[0]
    assert noisy.scores["bootstrap_share"].max() < precise.scores["bootstrap_share"].max()


def test_tables_are_consistent_with_an_independent_computation(sites):
    noise = synthetic_noise(sites, 2.5e6)
    result = calibrate_modulus(sites, DX, noise, moduli=(2.5e6, 6.3e6), n_bootstrap=50)
    # Texture level of one site at one E: one-by-one contact solves, energy average of the segments.
    site, modulus = "site 3", 6.3e6
    powers = [spectra.third_octave_levels(contact(z, DX, modulus, MEAN_PRESSURE, tol=1e-8).envelope, DX,
                                          periodic=True) for z in sites[site]]
    mine = result.texture_levels.filter((pl.col("site") == site) & (pl.col("youngs_modulus") == modulus))
    for band, level in zip(mine["band"], mine["level_db"]):
        expected = 10 * math.log10(np.mean([10 ** (p.filter(pl.col("band") == band)["level_db"].item() / 10)
                                            for p in powers]))
        assert level == pytest.approx(expected, abs=1e-6)
    # Correlations per (E, band) are Pearson's r of the returned levels (numpy.corrcoef).
    for row in result.correlations.iter_rows(named=True):
        texture = result.texture_levels.filter((pl.col("youngs_modulus") == row["youngs_modulus"])
                                               & (pl.col("band") == row["band"])).sort("site")
        measured = result.noise_levels.filter(pl.col("band") == row["band"]).sort("site")
        assert texture["site"].to_list() == measured["site"].to_list()
        r = np.corrcoef(texture["level_db"], measured["level_db"])[0, 1]
        assert row["correlation"] == pytest.approx(r, abs=1e-12)
        assert row["sites"] == len(sites)
    # Each E's score summarises its bands' r: it lies within their range, over the bands with an r.
    for row in result.scores.iter_rows(named=True):
        r = result.correlations.filter(pl.col("youngs_modulus") == row["youngs_modulus"])["correlation"].to_numpy()
        assert r.min() - 1e-12 <= row["mean_correlation"] <= r.max() + 1e-12
        assert row["bands"] == np.isfinite(r).sum()


def test_without_scatter_the_true_modulus_fits_every_band_exactly(sites):
    """With no scatter the noise is, band by band, an exact straight line of the texture level at
    the true E: there Pearson's r is 1 in every band, and so is their mean, and the regression's
    slope and intercept are the gain and offset the noise was made with. Every other E scores
    less than 1, and the bootstrap picks the true E."""
    truth, lines = 2.5e6, {}
    noise = synthetic_noise(sites, truth, scatter_db=0.0, lines=lines)
    result = calibrate_modulus(sites, DX, noise, moduli=MODULI, n_bootstrap=100)
    fit = result.correlations.filter(pl.col("youngs_modulus") == truth).sort("band")
    bands = fit["band"].to_list()
    assert bands == sorted(lines) and len(bands) >= 10
    np.testing.assert_allclose(fit["correlation"], 1.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fit["r2"], 1.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fit["slope"], [lines[b][0] for b in bands], rtol=1e-9)
    np.testing.assert_allclose(fit["intercept"], [lines[b][1] for b in bands], rtol=1e-9)
    scores = dict(zip(result.scores["youngs_modulus"], result.scores["mean_correlation"]))
    assert scores[truth] == pytest.approx(1.0, abs=1e-12)
    assert all(score < 1.0 - 1e-6 for modulus, score in scores.items() if modulus != truth), scores
    shares = dict(zip(result.scores["youngs_modulus"], result.scores["bootstrap_share"]))
    assert result.best_modulus == truth and shares[truth] > 0.9


def test_noise_by_frequency_and_as_an_array_give_the_same_answer(sites):
    noise = synthetic_noise(sites, 4.0e6)
    by_band = calibrate_modulus(sites, DX, noise, moduli=MODULI, n_bootstrap=100)
    # CPX levels come per frequency band: f = V / wavelength at 80 km/h maps back to the same bands.
    centre = dict(zip(*spectra.band_table(DX, POINTS * DX)[["band", "centre_wavelength"]]))
    by_frequency = noise.with_columns(
        pl.col("band").replace_strict(centre, return_dtype=pl.Float64).map_elements(
            lambda wavelength: spectra.time_frequency(wavelength, 80.0), return_dtype=pl.Float64).alias("frequency")
    ).drop("band")
    from_frequency = calibrate_modulus(sites, DX, by_frequency, moduli=MODULI, speed_kmh=80.0, n_bootstrap=100)
    bands = sorted(noise["band"].unique())
    wide = noise.pivot(on="band", index="site", values="level_db").sort("site")
    array = wide.select([str(b) for b in bands]).to_numpy()
    order = {site: i for i, site in enumerate(wide["site"])}
    from_array = calibrate_modulus({site: sites[site] for site in order}, DX, array, bands=bands, moduli=MODULI,
                                   n_bootstrap=100)
    for other in (from_frequency, from_array):
        assert other.best_modulus == by_band.best_modulus == 4.0e6
        np.testing.assert_allclose(other.scores["mean_correlation"], by_band.scores["mean_correlation"], rtol=1e-12)


def test_working_in_blocks_changes_nothing(sites, monkeypatch):
    """Solves and bootstrap resamples are split into blocks to bound memory; the answer must not move."""
    noise = synthetic_noise(sites, 2.5e6)
    whole = calibrate_modulus(sites, DX, noise, moduli=(1.6e6, 2.5e6, 4.0e6), n_bootstrap=200)
    monkeypatch.setattr(calibration, "BLOCK_VALUES", 3000)  # one segment, 7 resamples per block
    blocks = calibrate_modulus(sites, DX, noise, moduli=(1.6e6, 2.5e6, 4.0e6), n_bootstrap=200)
    assert blocks.interval == whole.interval and blocks.best_modulus == whole.best_modulus
    np.testing.assert_allclose(blocks.texture_levels["level_db"], whole.texture_levels["level_db"], atol=1e-9)
    np.testing.assert_array_equal(blocks.scores["bootstrap_share"], whole.scores["bootstrap_share"])


def test_default_grid_is_tenth_decades_from_1_to_10_mpa():
    """The tenth-decade values 10^(k/10) MPa, k = 0 .. 10, to four significant figures, against a
    table written out by hand (10^0.1 = 1.2589, 10^0.3 = 1.9953, 10^0.5 = sqrt 10 = 3.1623, ...),
    not the series' own formula."""
    tabulated = [1.0, 1.259, 1.585, 1.995, 2.512, 3.162, 3.981, 5.012, 6.310, 7.943, 10.0]
    assert list(calibration.DEFAULT_MODULI) == pytest.approx([1e6 * v for v in tabulated], rel=1e-12)
    grid = np.array(calibration.DEFAULT_MODULI)
    # a geometric series is symmetric about its middle: E_k E_(10-k) = (1 MPa)(10 MPa)
    np.testing.assert_allclose(grid * grid[::-1], 1e13, rtol=5e-4)


def bad_call(sites, **overrides):
    args = dict(profiles=sites, dx=DX, noise_levels=pl.DataFrame(
        [dict(site=s, band=27, level_db=90.0 + i) for i, s in enumerate(sites)]), moduli=(1e6, 2e6), n_bootstrap=10)
    args.update(overrides)
    return calibrate_modulus(**args)


def test_bad_input_raises_a_clear_value_error():
    z = np.stack([self_affine_profile(256, 256 * DX, seed=s) for s in range(2)])
    three = {"a": z, "b": z[0], "c": 2 * z}
    nan = z.copy()
    nan[1, 4] = np.nan
    cases = {
        r"2 sites.*at least 3": dict(profiles={"a": z, "b": z}),
        r"profiles\['b'\] row 1 contains a non-finite value \(NaN\) at index 4": dict(profiles={**three, "b": nan}),
        r"no level for the sites 'c'": dict(noise_levels=pl.DataFrame(
            [dict(site=s, band=27, level_db=1.0) for s in "ab"])),
        r"sites with no profile: 'd'": dict(noise_levels=pl.DataFrame(
            [dict(site=s, band=27, level_db=1.0) for s in "abcd"])),
        r"needs a 'band'.*or 'frequency'": dict(noise_levels=pl.DataFrame(dict(site=list("abc"), level_db=[1.0] * 3))),
        r"pass speed_kmh": dict(noise_levels=pl.DataFrame(dict(site=list("abc"), frequency=[1e3] * 3,
                                                               level_db=[1.0] * 3))),
        r"level_db contains NaN": dict(noise_levels=pl.DataFrame(dict(site=list("abc"), band=[27] * 3,
                                                                      level_db=[1.0, np.nan, 2.0]))),
        r"more than one level for site 'a' in band 27": dict(noise_levels=pl.DataFrame(
            dict(site=list("aabc"), band=[27] * 4, level_db=[1.0, 2.0, 3.0, 4.0]))),
        r"needs bands=": dict(noise_levels=np.ones((3, 1))),
        r"shape \(sites, bands\) = \(3, 1\)": dict(noise_levels=np.ones((3, 2)), bands=[27]),
        r"moduli must be a 1-D sequence of at least 2": dict(moduli=[2e6]),
        r"moduli must be positive": dict(moduli=[2e6, -1.0]),
        r"no band is both reported": dict(noise_levels=pl.DataFrame(dict(site=list("abc"), band=[3] * 3,
                                                                          level_db=[1.0, 2.0, 3.0]))),
        r"confidence must lie in \(0, 1\)": dict(confidence=1.0),
        r"n_bootstrap must be at least 1": dict(n_bootstrap=0),
        r"dx must be a positive finite": dict(dx=0.0),
        r"kind must be": dict(kind="twelfth"),
    }
    assert bad_call(three).best_modulus in (1e6, 2e6)  # the base call is valid
    for message, overrides in cases.items():
        with pytest.raises(ValueError, match=message):
            bad_call(three, **overrides)
