"""Coarse starts for model-grid solves (issue 39): contact_many(coarse_start=k) starts each solve on
a grid k times finer than the data from the data grid's answer. Counted in iterations, never in
seconds (benches/warm_start.py times it)."""

from __future__ import annotations

import numpy as np
import pytest

import roadtex
from roadtex.errors import InvalidInputError
from roadtex.models.grid import refine_periodic

MODULI = [1e6, 2e6, 5e6, 10e6]
P = 2e5
TOL = 1e-6


@pytest.fixture(scope="module")
def model() -> tuple[np.ndarray, float, int]:
    """Two 0.5 m segments of dense asphalt at 1 mm on the model grid 6 times finer (linear)."""
    k, dx = 6, 1e-3
    heights = roadtex.synthetic_pavement("dense_asphalt", 1.0, dx, seed=3).segments(0.5).heights
    return refine_periodic(heights, k, "linear"), dx / k, k


def test_the_coarse_start_takes_fewer_iterations_and_lands_within_tol_of_the_cold_solve(model) -> None:
    fine, dx, k = model
    cold = roadtex.contact_many(fine, dx, MODULI, P, tol=TOL, threads=1, warm_start=True)
    warm = roadtex.contact_many(fine, dx, MODULI, P, tol=TOL, threads=1, warm_start=True, coarse_start=k)
    warm2 = roadtex.contact_many(fine, dx, MODULI, P, tol=TOL, threads=2, warm_start=True, coarse_start=k)
    assert warm.converged.all() and (warm.residual <= TOL).all()
    assert np.array_equal(warm.pressure, warm2.pressure) and np.array_equal(warm.iterations, warm2.iterations)
    # the first modulus of each segment is the one the data grid starts (the others start from it)
    assert warm.iterations[:, 0].sum() < 0.8 * cold.iterations[:, 0].sum(), (warm.iterations, cold.iterations)
    assert np.allclose(warm.pressure.mean(axis=2), P, rtol=1e-12) and (warm.pressure >= 0).all()
    # both meet tol (the worst gap relative to the peak-to-valley height): their envelopes agree to 2 tol
    ptv = np.ptp(fine, axis=1)[:, None, None]
    assert np.max(np.abs(warm.envelope - cold.envelope) / ptv) <= 2 * TOL


def test_without_the_moduli_chain_every_modulus_starts_from_the_data_grid(model) -> None:
    fine, dx, k = model
    cold = roadtex.contact_many(fine, dx, MODULI, P, tol=TOL, threads=1)
    coarse = roadtex.contact_many(fine, dx, MODULI, P, tol=TOL, threads=1, coarse_start=k)
    assert coarse.converged.all() and (coarse.residual <= TOL).all()
    assert (coarse.iterations < cold.iterations).mean() > 0.9, (coarse.iterations, cold.iterations)
    # coarse_start=1: no coarser grid, the cold solves themselves
    same = roadtex.contact_many(fine, dx, MODULI, P, tol=TOL, threads=1, coarse_start=1)
    assert np.array_equal(same.pressure, cold.pressure)


def test_a_coarse_start_that_is_not_the_grid_of_the_segments_is_refused(model) -> None:
    fine, dx, _ = model
    with pytest.raises(InvalidInputError, match=r"coarse_start = 7: segments of 3000 points .* multiple of k"):
        roadtex.contact_many(fine, dx, MODULI, P, coarse_start=7)
    with pytest.raises(InvalidInputError, match=r"coarse_start"):
        roadtex.contact_many(fine, dx, MODULI, P, coarse_start=0)
