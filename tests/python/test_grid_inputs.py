"""The model grid's refinement (roadtex.models.grid) refuses what it cannot join or hold: a NaN or
infinite reading is one clear InvalidInputError whatever the interpolant (before: NaN spread over two
points by "linear", four by "pchip", every point by "bandlimited", without a word), and a refinement
or a grid beyond the stated limits is refused before it is allocated (``--refine 10000`` allocated
until the Rust core aborted the process)."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from roadtex.errors import InvalidInputError
from roadtex.models.grid import MAX_MODEL_POINTS, MAX_REFINE, refine_periodic, refine_periodic_surface

HEIGHTS = np.random.default_rng(3).normal(0.0, 1e-3, 64)


@pytest.mark.parametrize("interpolant", ["linear", "pchip", "bandlimited"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_non_finite_reading_is_one_clear_error_for_every_interpolant(interpolant: str, bad: float) -> None:
    z = HEIGHTS.copy()
    z[17] = bad
    with pytest.raises(InvalidInputError, match=r"1 non-finite reading\(s\) \(the first at index \(17,\)"):
        refine_periodic(z, 4, interpolant)
    with pytest.raises(InvalidInputError, match=r"the first at index \(1, 17\)"):
        refine_periodic_surface(np.stack([HEIGHTS, z]), 2, 2, interpolant)


def test_a_refinement_beyond_the_limit_is_refused_before_allocating() -> None:
    tracemalloc.start()
    try:
        with pytest.raises(InvalidInputError, match=f"refine must be at most {MAX_REFINE}"):
            refine_periodic(HEIGHTS, 10_000)
        with pytest.raises(InvalidInputError, match=f"k_across must be at most {MAX_REFINE}"):
            refine_periodic_surface(HEIGHTS.reshape(8, 8), 2, 10_000)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1_000_000


def test_a_grid_beyond_the_points_limit_is_refused_before_allocating() -> None:
    long_segment = np.zeros(MAX_MODEL_POINTS // 32 + 1)                 # a segment times 32: one point too many
    tile = np.zeros((256, 256))                                          # k^2 = 64 * 64 times 65,536 points
    tracemalloc.start()
    try:
        with pytest.raises(InvalidInputError, match=f"one segment would hold {long_segment.size * 32} points, beyond"):
            refine_periodic(long_segment, 32)
        with pytest.raises(InvalidInputError, match=f"one tile would hold {256 * 256 * 64 * 64} points"):
            refine_periodic_surface(tile, 64, 64)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1_000_000
    assert refine_periodic(long_segment[:-1], 32).size == MAX_MODEL_POINTS   # the limit itself is allowed
