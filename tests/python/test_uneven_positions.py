"""Uneven files are not files with missing rows, and a grid in mm is judged whole.

Rows missing from an export are counted as drop-outs (conditioning.sampling_interval,
missing_positions), but only in a file regular apart from its gaps: distances rounded more coarsely
than half the sampling, or jittered, must keep the mean step and invent no drop-out. And the
per-metre plausibility judgement must not fit away the texture of a grid whose dx is in mm.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex.errors import ImplausibleTextureWarning
from roadtex.profiles.conditioning import missing_positions, sampling_interval


def texture(n: int, seed: int = 0) -> np.ndarray:
    noise = np.random.default_rng(seed).standard_normal(n + 8)
    smooth = np.convolve(noise, np.ones(9) / 9, mode="valid")[:n]
    return 0.8e-3 * smooth / smooth.std()


def test_distances_rounded_coarser_than_half_the_sampling_are_not_gaps(tmp_path: Path) -> None:
    """0.15 mm sampling written to 0.1 mm (steps alternate 0.1 and 0.2 mm): read at 0.15 mm, no
    row missing, every MPD baseline valid (the gap reading gave 0.1 mm, a third of the readings
    missing and no valid baseline)."""
    n, dx = 20_000, 0.15e-3
    x = np.round(np.arange(n) * dx, 4)
    path = tmp_path / "rounded.csv"
    pl.DataFrame({"distance_m": x, "height_m": texture(n)}).write_csv(path)
    profile = roadtex.read_profile(path)
    assert profile.dx == pytest.approx(dx, rel=1e-3)
    assert not np.isnan(profile.heights).any()
    result = roadtex.mpd(profile)
    assert result.is_valid and result.valid_segments == len(result.msd) == 30


@pytest.mark.parametrize("sigma", [0.2, 0.3])
def test_jittered_steps_keep_the_mean_step_and_miss_no_row(sigma: float) -> None:
    dx = 0.5e-3
    steps = dx * (1 + sigma * np.random.default_rng(1).standard_normal(4000)).clip(0.05)
    x = np.concatenate([[0.0], np.cumsum(steps)])
    assert sampling_interval(x) == pytest.approx((x[-1] - x[0]) / (x.size - 1), rel=1e-12)
    assert missing_positions(x, sampling_interval(x)).size == 0


def test_rows_really_missing_are_still_found() -> None:
    """A regular 0.5 mm file with 3 stretches of rows removed (1, 4 and 10 rows): dx exact and the
    15 grid positions found."""
    dx = 0.5e-3
    keep = np.ones(2000, dtype=bool)
    keep[[100]] = False
    keep[500:504] = False
    keep[1200:1210] = False
    x = np.arange(2000)[keep] * dx
    assert sampling_interval(x) == pytest.approx(dx, rel=1e-12)
    assert missing_positions(x, dx).size == 15


@pytest.mark.parametrize("dx", [0.25, 0.5, 1.0])
def test_heights_and_dx_both_in_millimetres_still_warn(dx: float) -> None:
    """1000 samples of 0.8 mm rms texture, heights and dx in mm (a metre is then 1 to 4 samples:
    judged per metre, every line would fit the texture away)."""
    z_mm = 1000 * texture(1000, seed=2)
    with pytest.warns(ImplausibleTextureWarning, match="millimetres"):
        roadtex.contact(z_mm, dx, 2.5e6, 2e5, max_iterations=1, raise_on_nonconvergence=False)
