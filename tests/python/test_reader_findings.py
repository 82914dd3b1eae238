"""Files that were read to silently wrong numbers (the readers' adversarial findings): two runs in
one file, numeric drop-out codes, decimal commas in a comma-delimited file without a header, empty
cells at the ends of heights-only files, units stated in metadata lines, thousands separators and
rows with one field too many. Each is now read to the numbers written, or refused naming the file
and the line."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import roadtex
from roadtex.errors import ImplausibleTextureWarning, ProfileFormatError

DX_MM = 0.5


def texture(n: int, seed: int = 4) -> np.ndarray:
    """Heights (mm, three decimals) of an irregular 1.5 mm texture: no value repeats by design."""
    rng = np.random.default_rng(seed)
    x = np.arange(n) * DX_MM
    z = 1.5 * np.sin(2 * np.pi * x / 7.3) + 0.6 * np.cos(2 * np.pi * x / 2.9) + 0.2 * rng.standard_normal(n)
    return np.round(z, 3)


def read(path: Path, **options: object) -> roadtex.Profile:
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleTextureWarning)
        return roadtex.read_profile(path, **options)


def rows(x: np.ndarray, z: list[str] | np.ndarray, separator: str = ",") -> str:
    return "".join(f"{a:.3f}{separator}{b}\n" for a, b in zip(x, z))


# 1. Two runs in one file, the second restarting at distance 0

def test_a_second_run_restarting_at_zero_is_refused_naming_the_row(tmp_path: Path) -> None:
    n = 1200
    x = 62.5 + np.arange(n) * DX_MM
    half = n // 2
    # the second pass restarts at 0, 0.075 mm off the first one's grid: sorted, the two would interleave
    restarted = np.concatenate([x[:half], x[half:] - x[half] + 0.075])
    path = tmp_path / "two_passes.csv"
    path.write_text("distance (mm),height (mm)\n" + rows(restarted, texture(n)))
    with pytest.raises(ProfileFormatError, match=rf"two_passes\.csv: the distances restart at data row {half + 1} "
                                                 r"\(from 0\.362 m back to 7\.5e-05 m\): two runs in one file\? Split"):
        read(path)
    with pytest.raises(ProfileFormatError, match="restart at data row"):
        read(path, sort=False)


def test_a_file_written_in_reverse_and_rows_swapped_locally_are_still_sorted(tmp_path: Path) -> None:
    n = 800
    x, z = np.arange(n) * DX_MM, texture(n)
    reverse = tmp_path / "reverse.csv"
    reverse.write_text("distance (mm),height (mm)\n" + rows(x[::-1], z[::-1]))
    order = np.arange(n)
    order[[100, 101]], order[[500, 503]] = order[[101, 100]], order[[503, 500]]
    swapped = tmp_path / "swapped.csv"
    swapped.write_text("distance (mm),height (mm)\n" + rows(x[order], z[order]))
    for path in (reverse, swapped):
        profile = read(path)
        np.testing.assert_allclose(profile.positions, x * 1e-3, atol=1e-12)
        np.testing.assert_allclose(profile.heights, z * 1e-3, atol=1e-12)
        assert "sorted" in profile.history[-1]
