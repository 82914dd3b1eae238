"""The pilots' reference tolerance (``REFERENCE_TOL``, 1e-6 since 0.5.5, 1e-10 before): the reference
solves stand for the converged answer, so their levels must lie where a much tighter solve of the
same model grid puts them, within the Richardson rule's noise floor (``TINY_DIFFERENCE_DB``, far
below the budget). Judged against independent solves at tol 1e-10, for lines and surfaces."""

from __future__ import annotations

import numpy as np

import roadtex
from roads import job_road
from roadtex.budget import areal, study
from roadtex.budget.estimate import TINY_DIFFERENCE_DB, difference
from roadtex.models.grid import refine_periodic_surface
from roadtex.spectra.bands import REFERENCE_PRESSURE
from roadtex.surfaces import synthetic_surface

MODULI = np.array([1e6, 2e6, 5e6, 10e6])
TIGHT_TOL = 1e-10


def worst_difference(a: np.ndarray, b: np.ndarray) -> float:
    """Largest |a - b| (dB): bands without a DFT line (NaN in both) left out; a level without power
    in one and not in the other (a row in contact at one tol only) counts as infinite."""
    both_undefined = np.isnan(a) & np.isnan(b)
    return float(np.max(np.where(both_undefined, 0.0, difference(a, b))))


def line_levels(heights: np.ndarray, dx: float, tol: float) -> np.ndarray:
    """(2 kinds, segments x moduli, bands) enveloped and pressure levels, moduli chained."""
    batch = roadtex.contact_many(heights, dx, MODULI, 2e5, tol=tol, warm_start=True)
    n = heights.shape[0] * MODULI.size
    env = roadtex.band_levels(batch.envelope.reshape(n, -1), dx, periodic=True)
    pr = roadtex.band_levels(batch.pressure.reshape(n, -1), dx, periodic=True, reference=REFERENCE_PRESSURE)
    return np.stack([env.levels, pr.levels])


def test_line_reference_solves_are_converged_below_the_noise_floor() -> None:
    # porous asphalt at 1 mm, the monotone cubic road 4 times finer: the pilots' rungs as they solve
    profile = roadtex.synthetic_pavement("porous_asphalt", 2.0, 1e-3, seed=7)
    data = profile.conditioned(spike_alpha=None).segments(0.5)
    road, dx = job_road(data.heights, 4), data.dx / 4
    reference, tight = line_levels(road, dx, study.REFERENCE_TOL), line_levels(road, dx, TIGHT_TOL)
    worst = worst_difference(reference, tight)
    assert worst <= TINY_DIFFERENCE_DB, worst
    # and the tolerance is what the docs and the study claim: tighter than any candidate but the last
    assert min(study.DEFAULT_TOLERANCES) == study.REFERENCE_TOL


def test_areal_reference_solves_are_converged_below_the_noise_floor() -> None:
    # a 1 mm dense asphalt tile 8 mm wide, 2 times finer each way, every analysed row's levels
    surface = synthetic_surface("dense_asphalt", 0.128, 0.008, 1e-3, seed=5)
    fine = refine_periodic_surface(surface.heights[None], 2, 2)
    levels = {}
    for tol in (study.REFERENCE_TOL, TIGHT_TOL):
        solved = roadtex.contact_surface_many(fine, 0.5e-3, 0.5e-3, youngs_modulus=MODULI, mean_pressure=2e5, tol=tol)
        env = roadtex.band_levels(solved.envelope.reshape(-1, solved.envelope.shape[-1]), 0.5e-3, periodic=True)
        pr = roadtex.band_levels(solved.pressure.reshape(-1, solved.pressure.shape[-1]), 0.5e-3, periodic=True,
                                 reference=REFERENCE_PRESSURE)
        levels[tol] = np.stack([env.levels, pr.levels])
    worst = worst_difference(levels[study.REFERENCE_TOL], levels[TIGHT_TOL])
    assert worst <= TINY_DIFFERENCE_DB, worst
    assert areal.REFERENCE_TOL == study.REFERENCE_TOL
