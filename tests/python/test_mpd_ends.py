"""The ends of a profile in MPD: the zero-phase high-pass (ISO 13473-1's slope suppression by
filter, 174.2 mm), and the end shorter than a baseline that MPD leaves out.

The filter settles over some three cut-off wavelengths. Extended by scipy's default odd
reflection of 9 samples, a profile's first and last half metre came out biased: the end baselines
of a 1 mm cosine read 30 % and 52 % deep. The profile is now extended by its local line carried on
plus its texture mirrored (:func:`roadtex.profiles.conditioning.trend_and_mirror`).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from roadtex.profiles import Profile, mpd
from roadtex.profiles.conditioning import trend_and_mirror
from roadtex.profiles.pavements import synthetic_pavement

DX = 0.5e-3
CUTOFF = 0.1742


@pytest.mark.parametrize("grade", [0.0, 0.01, 0.03])
def test_every_baseline_of_a_graded_cosine_has_the_cosine_depth(grade: float) -> None:
    """1 mm cosine of 10 mm wavelength on 2 m at a grade: every 100 mm baseline's MSD within 1 %
    of the sampled crest (the highest sample sits dx/2 off a crest)."""
    x = DX * (np.arange(int(2.0 / DX)) + 0.5)
    z = 1e-3 * np.cos(2 * np.pi * x / 0.01) + grade * x
    result = mpd(Profile.from_heights(z, DX, start=0.5 * DX), lowpass_wavelength=None,
                 slope_suppression="highpass", trim_plates=False)
    crest = 1e-3 * math.cos(math.pi * DX / 0.01)
    assert len(result.msd) == 20
    np.testing.assert_allclose(result.msd, crest, rtol=0.01)


def test_a_piece_filtered_alone_matches_the_same_stretch_filtered_in_its_run() -> None:
    """Independent of any formula: a 2 m piece of a 6 m synthetic road at a 3 % grade, high-passed
    alone, against the same 2 m high-passed inside the 6 m run (whose ends are 2 m away): within
    0.6 mm everywhere, 0.05 mm beyond the first and last 0.5 m (the scipy reflection was off by up
    to 6 mm at the ends on such pieces)."""
    for kind, seed in [("dense_asphalt", 0), ("porous_asphalt", 1), ("cement_concrete", 2)]:
        road = synthetic_pavement(kind, 6.0, DX, seed=seed)
        z = road.heights + 0.03 * road.positions
        within = Profile.from_heights(z, DX).highpass(CUTOFF).heights[4000:8000]
        alone = Profile.from_heights(z[4000:8000], DX).highpass(CUTOFF).heights
        error = np.abs(alone - within)
        assert error.max() < 0.6e-3, kind
        assert error[1000:-1000].max() < 0.05e-3, kind


def test_trend_and_mirror_carries_a_line_on_and_mirrors_the_rest() -> None:
    """A line plus a texture symmetric about the ends comes back as the same line and texture
    continued: the extension of a + b k + c cos(2 pi k / 8) (k the sample) is that formula beyond
    the ends, to rounding (the cosine is even about k = 0 and about the last sample)."""
    k = np.arange(41, dtype=np.float64)
    formula = lambda i: 0.3 + 0.02 * i + 0.1 * np.cos(2 * np.pi * i / 8)  # noqa: E731 - the test's one formula
    pad = 8
    extended = trend_and_mirror(formula(k), pad)
    assert extended.size == k.size + 2 * pad
    np.testing.assert_allclose(extended, formula(np.arange(-pad, k.size + pad, dtype=np.float64)), atol=1e-3)


def test_mpd_states_the_end_it_leaves_out() -> None:
    """1.03 m at 0.5 mm: ten 100 mm baselines, and the last 30 mm (less than one) is stated as
    unused, in the result and in the profile's history; a whole number of baselines leaves none."""
    x = DX * (np.arange(int(round(1.03 / DX))) + 0.5)
    z = 1e-3 * np.cos(2 * np.pi * x / 0.01)
    result = mpd(Profile.from_heights(z, DX, start=0.5 * DX), lowpass_wavelength=None)
    assert len(result.msd) == 10
    assert result.unused_length == pytest.approx(0.03, abs=DX)
    assert "the last 30 mm, less than a segment, not used" in result.profile.history[-1]
    whole = mpd(Profile.from_heights(z[:2000], DX, start=0.5 * DX), lowpass_wavelength=None)
    assert whole.unused_length == 0.0 and "not used" not in whole.profile.history[-1]
