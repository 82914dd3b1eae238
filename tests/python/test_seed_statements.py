"""The seed's statements as one call each (roadtex.comparisons.seed): closed forms where one exists
(Westergaard's full contact for figure 4.6, the von Meier parabola for 4.3), physics that could fail
otherwise."""

from __future__ import annotations

import math

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex import comparisons as cmp
from roadtex.errors import InvalidInputError


@pytest.mark.parametrize("method", ["dft", "filter"])
def test_pressure_texture_fit_recovers_westergaard_slope_and_intercept(method):
    """Sines of one band-centre wavelength and amplitudes small enough for full contact
    (p* = pi E* A / lambda < P): the rubber follows the profile and the pressure is Westergaard's,
    P + p* cos, so the pressure level is the texture level plus 20 lg(pi E* 1 um / lambda / 1 Pa)
    exactly: slope 1, that intercept, no scatter."""
    band = 27                                   # third octave centred on 10^-2.7 m = 1.995 mm
    wavelength = 10.0 ** (-band / 10.0)
    n, cycles = 1024, 16
    dx = wavelength * cycles / n
    modulus = 1e6
    e_star = modulus / (1 - 0.25)
    amplitudes = np.geomspace(5e-6, 5e-5, 7)
    assert math.pi * e_star * amplitudes.max() / wavelength < 2e5
    x = np.arange(n)
    segments = amplitudes[:, None] * np.cos(2 * np.pi * cycles * x / n)[None, :]
    check = cmp.pressure_texture_fits(segments, dx, youngs_moduli=[modulus], kind="third_octave", method=method,
                                      tol=1e-12)
    fit = check.summary.filter(pl.col("band") == band).row(0, named=True)
    expected = 20 * np.log10(math.pi * e_star * 1e-6 / wavelength)
    # The slope is exact (the model is linear in full contact); the intercept carries the element
    # discretisation of the kernel at 64 points per wavelength (0.003 dB) and, for the filters, their
    # gain at the centre.
    slope_tolerance, intercept_tolerance = (1e-6, 0.01) if method == "dft" else (0.01, 0.05)
    assert fit["slope"] == pytest.approx(1.0, abs=slope_tolerance)
    assert fit["intercept"] == pytest.approx(expected, abs=intercept_tolerance)
    assert fit["scatter_db"] < intercept_tolerance and fit["n"] == amplitudes.size
    assert check.data.filter(pl.col("band") == band).height == amplitudes.size


def test_penetration_ranking_on_v_valleys_follows_the_parabola_and_the_elastic_law():
    """A row of V valleys between sharp peaks, widths 1 to 8 mm, each deeper than the von Meier sag so
    that the envelope rests on the peaks: the von Meier median of each width class is d* w^2 / 4 of
    its valleys (the parabola), and the INRETS rubber, whose sag grows about linearly with width,
    matches a softer modulus in the widest class than in the narrowest (the ranking we find on real
    profiles, opposite to the seed's), so the seed's statement does not hold here."""
    dx = 1e-4
    rng = np.random.default_rng(2)
    halves = rng.integers(5, 41, size=60)                 # flank lengths: widths 1 to 8 mm
    z = [0.0]
    for half in halves:
        depth = 3 * cmp.SEED_D_STAR * (half * dx) ** 2 + 0.2e-3
        j = np.arange(1, 2 * half + 1)
        z.extend(-depth * (1 - np.abs(j - half) / half))
    z = np.array(z[:-1])                                  # periodic: the last peak is the first
    check = cmp.penetration_ranking(z, dx, classes=3, tol=1e-9)
    data = check.data.filter(pl.col("youngs_modulus") == 1e6)
    for k, row in enumerate(check.summary.iter_rows(named=True)):
        widths = data.filter(pl.col("width_class") == k)["width"].to_numpy()
        assert row["von_meier_median"] == pytest.approx(np.median(cmp.SEED_D_STAR * widths**2 / 4), rel=1e-9)
    narrow, wide = check.summary.row(0, named=True), check.summary.row(check.summary.height - 1, named=True)
    assert narrow["width_median"] < wide["width_median"]
    # The narrowest valleys' von Meier penetration is below INRETS's at 10 MPa (stiffer than all),
    # the widest one's between 2 and 5 MPa.
    assert (narrow["modulus_below"], narrow["modulus_above"]) == (1e7, None)
    assert wide["modulus_above"] is not None and wide["modulus_above"] <= 5e6
    assert wide["matched_modulus"] is not None and 2e6 < wide["matched_modulus"] < 5e6
    assert not check.holds


def test_penetration_ranking_refuses_a_single_class():
    with pytest.raises(InvalidInputError, match="classes"):
        cmp.penetration_ranking(np.sin(np.arange(64)) * 1e-4, 1e-4, classes=1)


def test_envelopment_removes_most_of_porous_asphalts_depth_effect():
    """Synthetic porous against dense asphalt: the porous surface's texture levels are above the
    dense one's in every band, by 4 to 18 dB from 16 to 2 mm (its stones and pores) and 1 to 3 dB
    below that (the segments are seamless: their wrap step once added 4 to 8 dB there); after
    envelopment the excess falls by at least 3 dB wherever it was over 4 dB from 10 mm down, at
    every E, and is gone (<= 1 dB) in most bands from 10 mm down."""
    dx = 0.1e-3
    profiles = {kind: roadtex.synthetic_pavement(kind, 1.6, dx, seed=1).heights
                for kind in ("porous_asphalt", "dense_asphalt")}
    check = cmp.depth_effect(profiles, dx, porous="porous_asphalt", dense="dense_asphalt", segment_length=0.2)
    summary = check.summary
    assert summary["depth_effect_original_db"].min() > 1.0
    short = summary.filter(pl.col("centre_wavelength") <= 0.0101)
    assert short.height >= 4 * 13
    strong = short.filter(pl.col("depth_effect_original_db") > 4.0)
    assert strong["band"].n_unique() >= 6
    assert strong["reduction_db"].min() > 3.0
    assert short["removed"].mean() >= 0.8
    assert set(check.data["profile"].unique()) == {"porous_asphalt", "dense_asphalt"}
    with pytest.raises(InvalidInputError, match="porous"):
        cmp.depth_effect(profiles, dx, porous="porous", dense="dense_asphalt")
