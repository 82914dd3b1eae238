"""Seamless segments for the periodic model: each segment less the line through its ends, so that
the periodic extension (the contact model's, the periodic band levels') has no step at the wrap.

Accuracy is checked against independent levels: the exact band levels of a hand-built texture
(sines with a whole number of cycles per segment) and the whole record's Hann-windowed levels."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex.archive import ProcessingOptions
from roadtex.archive.compute import compute_run
from roadtex.budget.study import cleaned_profiles, segments_of
from roadtex.comparisons import seed
from roadtex.errors import InvalidInputError
from roadtex.profiles import write_profile
from roadtex.profiles.trend import remove_end_lines
from roadtex.spectra import band_levels
from roadtex.spectra.bands import band_table

SEGMENT = 0.5     # m
AMPLITUDE = 5e-6   # m, each sine of the low-level texture


def stepped_texture(dx: float, segments: int = 4, seed_: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Low-level texture (60 sines of 5 um with whole numbers of cycles per 0.5 m, wavelengths
    from 4 mm down to the shortest reported band: 1.25 mm at 0.5 mm, 0.4 mm at 0.1 mm) on a long
    wave (5 mm at 0.9 m) that leaves the segments' ends 1.4 to 2.8 mm apart after their
    least-squares lines: heights (m) and the sines' wavelengths (m)."""
    n = int(round(SEGMENT / dx))
    x = np.arange(segments * n) * dx
    rng = np.random.default_rng(seed_)
    cycles = rng.choice(np.arange(125, min(n // 2.5, 1250)), 60, replace=False)
    texture = sum(AMPLITUDE * np.sin(2 * np.pi * m * x / SEGMENT + rng.uniform(0, 2 * np.pi)) for m in cycles)
    return texture + 5e-3 * np.sin(2 * np.pi * x / 0.9 + 0.3), SEGMENT / cycles


def exact_levels(bands: pl.DataFrame, wavelengths: np.ndarray) -> np.ndarray:
    """The hand-built texture's band levels (dB re 1 um): the sines' mean squares in each band."""
    lower, upper = bands["lower_wavelength"].to_numpy(), bands["upper_wavelength"].to_numpy()
    count = np.array([np.sum((wavelengths > lo) & (wavelengths <= hi)) for lo, hi in zip(lower, upper)])
    with np.errstate(divide="ignore"):
        return 10 * np.log10(count * AMPLITUDE**2 / 2 / 1e-12)


def periodic_levels(heights: np.ndarray, dx: float) -> tuple[np.ndarray, pl.DataFrame]:
    result = band_levels(heights, dx, periodic=True)
    return 10 * np.log10(result.mean_square.mean(axis=0) / 1e-12), result.bands


@pytest.mark.parametrize("dx", [0.5e-3, 0.1e-3])
def test_seamless_periodic_levels_match_the_texture_and_the_hann_levels(dx: float) -> None:
    heights, wavelengths = stepped_texture(dx)
    profile = roadtex.Profile.from_heights(heights, dx)
    hann = band_levels(heights[None, :], dx, periodic=False).levels[0]
    old = profile.segments(SEGMENT, detrend="least_squares").heights
    assert np.sqrt(np.mean((old[:, -1] - old[:, 0]) ** 2)) > 1.5e-3   # the ends meet at a 2 mm step
    new = profile.segments(SEGMENT).heights
    new_levels, bands = periodic_levels(new, dx)
    old_levels, _ = periodic_levels(old, dx)
    exact = exact_levels(bands, wavelengths)
    shortest = np.flatnonzero(bands["reported"].to_numpy() & np.isfinite(exact))[-3:]
    assert bands["centre_wavelength"][int(shortest[0])] < 2.1e-3
    np.testing.assert_allclose(new_levels[shortest], hann[shortest], atol=0.5)
    np.testing.assert_allclose(new_levels[shortest], exact[shortest], atol=0.2)
    # the least-squares segments' wrap step inflates the same bands by more than the tolerance
    assert np.max(old_levels[shortest] - exact[shortest]) > 1.0
    assert np.abs(new[:, -1] - new[:, 0]).max() < 1e-15


def test_remove_end_lines_closes_the_ends_at_zero_mean() -> None:
    rng = np.random.default_rng(0)
    values = rng.normal(size=(5, 300)) + np.linspace(0, 3, 300)
    detrended, trend = remove_end_lines(values)
    np.testing.assert_allclose(detrended + trend, values, rtol=0, atol=1e-14)
    np.testing.assert_allclose(detrended[:, 0], detrended[:, -1], rtol=0, atol=1e-14)
    np.testing.assert_allclose(detrended.mean(axis=1), 0.0, atol=1e-15)
    # the trend is a straight line through the ends (with the mean's offset): second differences 0
    np.testing.assert_allclose(np.diff(trend, 2, axis=1), 0.0, atol=1e-14)
    # positions in metres give the same line as the sample index
    again, _ = remove_end_lines(values, 1e-4 * np.arange(300))
    np.testing.assert_allclose(again, detrended, rtol=0, atol=1e-13)
    # a line is removed exactly; a periodic signal is left as it is (less its mean)
    x = np.arange(400)
    line = 2.0 + 0.01 * x
    np.testing.assert_allclose(remove_end_lines(line)[0], 0.0, atol=1e-13)
    wave = 1 + np.cos(2 * np.pi * x / 399)          # equal ends (sample 0 and 399)
    np.testing.assert_allclose(remove_end_lines(wave)[0], wave - wave.mean(), atol=1e-13)


@pytest.mark.parametrize("detrend", ["ends", True, "least_squares", False])
@pytest.mark.parametrize("method", ["crossfade", "centre"])
def test_trends_restore_the_profile_and_stitch_gives_it_back(detrend: object, method: str) -> None:
    profile = roadtex.synthetic_pavement("porous_asphalt", 0.6, 0.5e-3, seed=2)
    s = profile.segments(0.128, overlap=0.032, detrend=detrend)
    np.testing.assert_allclose(s.heights + s.trends, profile.heights[s.start_indices[:, None] + np.arange(256)],
                               rtol=0, atol=1e-15)
    _, back = s.stitch(s.heights, method=method, add_trend=True)
    np.testing.assert_allclose(back, profile.heights, rtol=0, atol=1e-15)
    if detrend in ("ends", True):
        assert s.detrend == "ends"
        np.testing.assert_allclose(s.heights[:, 0], s.heights[:, -1], atol=1e-15)
        np.testing.assert_allclose(s.heights.mean(axis=1), 0.0, atol=1e-16)
    elif detrend is False:
        assert s.detrend is None and not s.trends.any()


def test_segments_detrend_is_checked() -> None:
    profile = roadtex.synthetic_pavement("dense_asphalt", 0.3, 0.5e-3, seed=1)
    with pytest.raises(InvalidInputError, match="detrend must be"):
        profile.segments(0.1, detrend="linear")  # type: ignore[arg-type]


def test_the_job_and_its_pilot_analyse_seamless_segments(tmp_path: Path) -> None:
    """The job's original levels are those of the hand-built texture (its segments' ends meet),
    and the error budget's pilot cuts the very segments the job solves."""
    dx = 0.5e-3
    heights, wavelengths = stepped_texture(dx)
    path = write_profile(roadtex.Profile.from_heights(heights, dx), tmp_path / "stepped.parquet")
    options = ProcessingOptions(youngs_moduli=(2.5e6,), segment_length=SEGMENT, dx=dx, tol=1e-6, spike_alpha=None,
                                refine=1)
    tables = compute_run({"path": str(path), "run_id": "stepped"}, options)
    texture = (tables["bands"].filter(pl.col("reported"))
               .group_by("band").agg((10 ** (pl.col("texture_level") / 10)).mean().log10().mul(10).alias("level"))
               .join(band_table(dx, SEGMENT), on="band").sort("band"))
    exact = exact_levels(texture, wavelengths)
    shortest = np.flatnonzero(np.isfinite(exact))[-3:]
    np.testing.assert_allclose(texture["level"].to_numpy()[shortest], exact[shortest], atol=0.2)

    profile = roadtex.Profile.from_heights(heights, dx)
    pilot, _, _ = segments_of(cleaned_profiles([profile], None), None, SEGMENT)
    job = profile.conditioned(spike_alpha=None).segments(options.segment_length, options.segment_overlap)
    np.testing.assert_array_equal(pilot, job.heights)
    np.testing.assert_allclose(pilot[:, 0], pilot[:, -1], atol=1e-15)


def test_the_seed_comparisons_analyse_seamless_segments() -> None:
    """depth_effect's original levels (periodic, its own segments) are the hand-built texture's."""
    dx = 0.5e-3
    heights, wavelengths = stepped_texture(dx)
    check = seed.depth_effect({"stepped": heights, "other": stepped_texture(dx, seed_=4)[0]}, dx, porous="stepped",
                              dense="other", youngs_moduli=(2.5e6,), segment_length=SEGMENT)
    original = check.data.filter(pl.col("profile") == "stepped").join(band_table(dx, SEGMENT), on="band").sort("band")
    exact = exact_levels(original, wavelengths)
    shortest = np.flatnonzero(np.isfinite(exact))[-3:]
    np.testing.assert_allclose(original["original_db"].to_numpy()[shortest], exact[shortest], atol=0.2)
