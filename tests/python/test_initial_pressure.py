"""Starts from a neighbouring answer (issue 39): contact_many(initial_pressure=...) starts each
(segment, modulus) solve from its own pressure, e.g. the same readings joined by another road on
the same grid (the pilot's interpolants' spread). Counted in iterations, never in seconds."""

from __future__ import annotations

import numpy as np
import pytest

import roadtex
from roadtex.budget.study import build_pilot, interpolant_spread, match, segments_of
from roadtex.errors import InvalidInputError
from roadtex.models.grid import refine_periodic

MODULI = [1e6, 2e6, 5e6, 10e6]
P = 2e5
TOL = 1e-6


@pytest.fixture(scope="module")
def roads() -> tuple[np.ndarray, np.ndarray, float]:
    """Three 0.5 m segments of porous asphalt at 1 mm on a grid 8 times finer, joined by the
    monotone cubic and by straight lines."""
    k, dx = 8, 1e-3
    heights = roadtex.synthetic_pavement("porous_asphalt", 1.5, dx, seed=5).segments(0.5).heights
    return refine_periodic(heights, k, "pchip"), refine_periodic(heights, k, "linear"), dx / k


def test_another_roads_answer_starts_every_solve_and_lands_within_tol_of_the_chained_one(roads) -> None:
    cubic, linear, dx = roads
    own = roadtex.contact_many(cubic, dx, MODULI, P, tol=1e-10, threads=1, warm_start=True)
    chained = roadtex.contact_many(linear, dx, MODULI, P, tol=TOL, threads=1, warm_start=True)
    started = roadtex.contact_many(linear, dx, MODULI, P, tol=TOL, threads=1, initial_pressure=own.pressure)
    again = roadtex.contact_many(linear, dx, MODULI, P, tol=TOL, threads=2, initial_pressure=own.pressure)
    assert started.converged.all() and (started.residual <= TOL).all()
    assert np.array_equal(started.pressure, again.pressure) and np.array_equal(started.iterations, again.iterations)
    # every modulus starts next to its answer: fewer iterations than the chain (whose first is cold)
    assert started.iterations.sum() < 0.85 * chained.iterations.sum(), (started.iterations, chained.iterations)
    assert np.allclose(started.pressure.mean(axis=2), P, rtol=1e-12) and (started.pressure >= 0).all()
    # both meet tol (the worst gap relative to the peak-to-valley height): envelopes agree to 2 tol
    ptv = np.ptp(linear, axis=1)[:, None, None]
    assert np.max(np.abs(started.envelope - chained.envelope) / ptv) <= 2 * TOL


def test_a_start_that_already_meets_tol_is_kept_without_an_iteration(roads) -> None:
    cubic, _, dx = roads
    tight = roadtex.contact_many(cubic, dx, MODULI, P, tol=1e-10, threads=1, warm_start=True)
    loose = roadtex.contact_many(cubic, dx, MODULI, P, tol=TOL, threads=1, initial_pressure=tight.pressure)
    assert (loose.iterations == 0).all() and loose.converged.all()
    assert np.allclose(loose.pressure, tight.pressure, rtol=1e-12, atol=1e-9 * P)


def test_initial_pressures_of_the_wrong_shape_or_sign_are_refused(roads) -> None:
    cubic, _, dx = roads
    shape = (cubic.shape[0], len(MODULI), cubic.shape[1])
    with pytest.raises(InvalidInputError, match=r"initial_pressure must have shape .*\(3, 4, 4000\), got \(3, 3, 4000\)"):
        roadtex.contact_many(cubic, dx, MODULI, P, initial_pressure=np.full((3, 3, 4000), P))
    with pytest.raises(InvalidInputError, match=r"initial_pressure must be finite pressures >= 0"):
        roadtex.contact_many(cubic, dx, MODULI, P, initial_pressure=np.full(shape, -P))
    with pytest.raises(InvalidInputError, match=r"initial_pressure must be finite"):
        roadtex.contact_many(cubic, dx, MODULI, P, initial_pressure=np.full(shape, np.nan))


def test_the_pilot_spread_from_the_job_roads_pressures_matches_the_spread_solved_without_them() -> None:
    """The interpolants' spread started from the job's road on the same grid: the same spread (dB)
    to far below its own size (both solves meet SPREAD_TOL)."""
    profile = roadtex.synthetic_pavement("porous_asphalt", 1.5, 1e-3, seed=5)
    pilot = build_pilot(profile, youngs_moduli=MODULI, mean_pressure=P, poisson=0.5, segment_length=0.5,
                        n_segments=3, band_kind="third_octave", spike_alpha=None, max_iterations=2000, threads=1,
                        max_refine=8)
    heights, _, dx = segments_of(pilot.cleaned, None, 0.5)
    heights = heights[match(pilot.starts, pilot.pilot)]
    k = pilot.refine
    own = roadtex.contact_many(refine_periodic(heights, k, pilot.interpolant), dx / k, MODULI, P, tol=1e-10,
                               threads=1, warm_start=True)
    started = interpolant_spread(pilot, heights, {k: own.pressure})
    cold = interpolant_spread(pilot, heights)
    assert pilot.interpolant_spread is not None and np.nanmax(cold) > 0.05
    assert np.array_equal(np.isnan(started), np.isnan(cold))
    assert np.nanmax(np.abs(started - cold)) < 1e-3, (started, cold)
