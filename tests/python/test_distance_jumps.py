"""A jump in a profile's distance column (issue 38): a 1 km jump in 2 m of 1 mm readings was
averaged into a 0.5 m "sampling interval" and refused as distances in millimetres read as metres.
A jump is two runs joined in one file or a corrupt distance: refused as a jump, naming its size
and where it is; rows missing over a shorter stretch stay drop-outs on the grid."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import roadtex
from roadtex.errors import ProfileFormatError, RoadtexWarning

RNG = np.random.default_rng(38)


def write(path: Path, x: np.ndarray) -> Path:
    z = RNG.normal(0.0, 0.5, x.size)   # mm
    path.write_text("distance (m),height (mm)\n" + "".join(f"{a:.4f},{b:.4f}\n" for a, b in zip(x, z)), encoding="utf-8")
    return path


@pytest.mark.parametrize("jump", [1000.0, 1000.00037, 5.0])   # a whole number of steps or not; 5 m > the 2 m read
def test_a_jump_is_refused_as_a_jump_not_a_unit_mistake(tmp_path: Path, jump: float) -> None:
    x = np.r_[np.arange(1000) * 1e-3, jump + np.arange(1000) * 1e-3]
    path = write(tmp_path / "joined.csv", x)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RoadtexWarning)   # no "were its distances in millimetres?" either
        with pytest.raises(ProfileFormatError) as caught:
            roadtex.read_profile(path)
    message = str(caught.value)
    assert message.startswith("joined.csv: the distances jump by ")
    assert f"between readings 1000 and 1001 by distance (0.999 m to {jump:.6g} m)" in message.replace("  ", " ")
    assert "0.001 m apart" in message and "not a unit mistake" in message


def test_a_gap_shorter_than_the_file_is_read_as_dropouts(tmp_path: Path) -> None:
    x = np.r_[np.arange(1000) * 1e-3, 2.2 + np.arange(1000) * 1e-3]   # 1.2 m of rows missing, 2 m read
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RoadtexWarning)   # the conditioning's drop-out share is not this test's
        profile = roadtex.read_profile(write(tmp_path / "gap.csv", x))
    assert profile.dx == pytest.approx(1e-3, rel=1e-9)
    assert "1200 rows missing (gaps in the distances), drop-outs on the grid" in profile.history[-1]
    on_grid = profile.resample(1e-3)
    assert len(on_grid) == 3200 and int(np.isnan(on_grid.heights).sum()) == 1200
