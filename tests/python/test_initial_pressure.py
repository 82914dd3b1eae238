"""Starts from a neighbouring answer (issue 39): contact_many(initial_pressure=...) starts each
(segment, modulus) solve from its own pressure, e.g. the same readings joined by another road on
the same grid (the pilot's interpolants' spread). Counted in iterations, never in seconds."""

from __future__ import annotations

import numpy as np
import pytest

import roadtex
from roadtex.budget import study
from roadtex.budget.study import build_pilot, interpolant_spread, match, segments_of
from roadtex.errors import InvalidInputError
from roadtex.models.grid import prolong_pressure, refine_periodic

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
    # one start per problem: a chain or a coarse start beside it would be silently ignored
    for other in ({"warm_start": True}, {"coarse_start": 8}):
        with pytest.raises(InvalidInputError, match=r"leave warm_start and coarse_start unset"):
            roadtex.contact_many(cubic, dx, MODULI, P, initial_pressure=np.full(shape, P), **other)


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


def test_a_pressure_prolonged_is_linear_between_its_points_keeps_its_mean_and_wraps() -> None:
    coarse = np.array([[0.0, 2.0, 4.0, 2.0], [1.0, 1.0, 1.0, 5.0]])
    fine = prolong_pressure(coarse, 2)
    assert np.array_equal(fine[0], [0.0, 1.0, 2.0, 3.0, 4.0, 3.0, 2.0, 1.0])
    assert np.array_equal(fine[1], [1.0, 1.0, 1.0, 1.0, 1.0, 3.0, 5.0, 3.0])   # the last interval wraps to the first point
    thrice = prolong_pressure(coarse, 3)
    assert np.array_equal(thrice[:, ::3], coarse) and np.allclose(thrice.mean(axis=1), coarse.mean(axis=1), rtol=1e-15)
    assert prolong_pressure(coarse, 1) is coarse


def test_each_rung_of_the_pilots_reference_starts_from_the_last(monkeypatch: pytest.MonkeyPatch) -> None:
    """The reference's rungs k = 2, 4, ... start from the rung below (its pressures prolonged), the
    interpolants' spread from the job's road on its grid; the first rung solves as the job does
    (moduli chained)."""
    calls: list[tuple[float, int, tuple[int, ...] | None]] = []
    original = study.contact_many

    def spy(model, dx, moduli, p, **kwargs):
        start = kwargs.get("initial_pressure")
        calls.append((kwargs["tol"], model.shape[1], None if start is None else start.shape))
        return original(model, dx, moduli, p, **kwargs)

    monkeypatch.setattr(study, "contact_many", spy)
    profile = roadtex.synthetic_pavement("dense_asphalt", 1.5, 1e-3, seed=4)
    pilot = build_pilot(profile, youngs_moduli=MODULI, mean_pressure=P, poisson=0.5, segment_length=0.5,
                        n_segments=3, band_kind="third_octave", spike_alpha=None, max_iterations=2000, threads=1,
                        max_refine=8)
    # the ladder first, then the spread (both at 1e-6 since 0.5.5: told apart by their order)
    assert [tol for tol, _, _ in calls] == [study.REFERENCE_TOL] * len(pilot.sequence) + [study.SPREAD_TOL]
    rungs = [(n, start) for _, n, start in calls[:len(pilot.sequence)]]
    assert pilot.refine >= 2 and [n for n, _ in rungs] == [500 * k for k in sorted(pilot.sequence)]
    assert rungs[0][1] is None
    assert all(start == (3, len(MODULI), n) for n, start in rungs[1:])
    spread = [(n, start) for _, n, start in calls[len(pilot.sequence):]]
    assert spread == [(500 * pilot.refine, (3, len(MODULI), 500 * pilot.refine))], spread
