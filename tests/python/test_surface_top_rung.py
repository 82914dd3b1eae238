"""The areal pilot's finest rung (issue 40): its reference carried on from its job-like solve at
the loosest tolerance (contact_surface_many(initial_pressure=...)) instead of solved again from a
nested start. Counted in solves and iterations, never in seconds; the statements checked against
the nested reference's."""

from __future__ import annotations

import numpy as np
import pytest

from roadtex.budget import areal
from roadtex.budget.study import DEFAULT_TOLERANCES, REFERENCE_TOL
from roadtex.errors import InvalidInputError
from roadtex.models import surface as surface_model
from roadtex.models.grid import refine_periodic_surface
from roadtex.models.surface import contact_surface_many
from roadtex.surfaces import synthetic_surface
from test_surface_errors import pilot_at

MODULI = np.array([2e6, 1e7])
PRESSURE = 2e5
DX = 1e-3


@pytest.fixture(scope="module")
def fine_tile() -> np.ndarray:
    """A dense asphalt tile of 64 x 16 mm at 1 mm on a grid 4 times finer each way."""
    surface = synthetic_surface("dense_asphalt", 0.064, 0.016, DX, seed=3)
    return refine_periodic_surface((surface.heights - surface.heights.mean())[None], 4, 4)


def test_a_looser_answer_carried_on_meets_the_tighter_tol_in_fewer_iterations(fine_tile) -> None:
    h = DX / 4
    loose = contact_surface_many(fine_tile, h, h, youngs_modulus=MODULI, mean_pressure=PRESSURE, tol=1e-3,
                                 warm_start=True, threads=1)
    nested = contact_surface_many(fine_tile, h, h, youngs_modulus=MODULI, mean_pressure=PRESSURE, tol=1e-6, threads=1)
    carried = contact_surface_many(fine_tile, h, h, youngs_modulus=MODULI, mean_pressure=PRESSURE, tol=1e-6,
                                   initial_pressure=loose.pressure, threads=1)
    again = contact_surface_many(fine_tile, h, h, youngs_modulus=MODULI, mean_pressure=PRESSURE, tol=1e-6,
                                 initial_pressure=loose.pressure, threads=2)
    tight = contact_surface_many(fine_tile, h, h, youngs_modulus=MODULI, mean_pressure=PRESSURE, tol=1e-10, threads=1)
    assert carried.converged.all() and (carried.residual <= 1e-6).all()
    assert np.array_equal(carried.pressure, again.pressure) and np.array_equal(carried.iterations, again.iterations)
    assert carried.iterations.sum() < nested.iterations.sum(), (carried.iterations, nested.iterations)
    assert np.allclose(carried.pressure.mean(axis=(2, 3)), PRESSURE, rtol=1e-12)
    # as close to the converged answer as the nested start's solve, within a few times
    off = [np.abs(b.pressure - tight.pressure).max() for b in (carried, nested, loose)]
    assert off[0] <= 3 * off[1] + 1e-3 * PRESSURE and off[0] < off[2] / 3, off


def test_an_answer_that_already_meets_tol_is_kept_without_an_iteration(fine_tile) -> None:
    h = DX / 4
    tight = contact_surface_many(fine_tile, h, h, youngs_modulus=MODULI, mean_pressure=PRESSURE, tol=1e-10, threads=1)
    kept = contact_surface_many(fine_tile, h, h, youngs_modulus=MODULI, mean_pressure=PRESSURE, tol=1e-6,
                                initial_pressure=tight.pressure, threads=1)
    assert (kept.iterations == 0).all() and kept.converged.all()
    assert np.allclose(kept.pressure, tight.pressure, rtol=1e-12, atol=1e-9 * PRESSURE)


def test_initial_pressures_of_the_wrong_shape_or_sign_or_with_a_chain_are_refused(fine_tile) -> None:
    h, (count, ny, nx) = DX / 4, fine_tile.shape
    good = np.full((count, MODULI.size, ny, nx), PRESSURE)
    common = dict(youngs_modulus=MODULI, mean_pressure=PRESSURE)
    with pytest.raises(InvalidInputError, match=r"initial_pressure must have shape \(tiles, moduli, ny, nx\) = "
                                                r"\(1, 2, 64, 256\), got \(1, 1, 64, 256\)"):
        contact_surface_many(fine_tile, h, h, initial_pressure=good[:, :1], **common)
    with pytest.raises(InvalidInputError, match=r"finite pressures >= 0"):
        contact_surface_many(fine_tile, h, h, initial_pressure=-good, **common)
    with pytest.raises(InvalidInputError, match=r"finite pressures >= 0"):
        contact_surface_many(fine_tile, h, h, initial_pressure=np.where(good > 0, np.nan, good), **common)
    with pytest.raises(InvalidInputError, match=r"leave warm_start False"):
        contact_surface_many(fine_tile, h, h, initial_pressure=good, warm_start=True, **common)


def pilot(budget_db: float) -> areal.SurfaceErrors:
    """test_surface_errors' pilot of a dense asphalt tile, its k chosen (1, 2, 4, 8)."""
    return pilot_at(DEFAULT_TOLERANCES, budget_db, refine=None)


def test_the_finest_rungs_reference_is_carried_on_from_its_job_like_solve(monkeypatch: pytest.MonkeyPatch) -> None:
    """At a budget no rung below the finest can meet (1 mm surfaces): the finest rung is solved once
    at the loosest tol as the job solves it, carried on to the reference tol, and that solve serves
    the tolerance step too; the statements are the nested reference's to within 1e-3 dB."""
    calls: list[tuple[int, float, bool]] = []
    real = surface_model.contact_surface_many

    def counting(tiles, dx, dy=None, **kwargs):
        calls.append((round(DX / dx), kwargs["tol"], kwargs.get("initial_pressure") is not None))
        return real(tiles, dx, dy, **kwargs)

    monkeypatch.setattr(areal, "contact_surface_many", counting)
    carried = pilot(budget_db=0.05)
    top, loosest = areal.REFINE_LADDER[-1], max(DEFAULT_TOLERANCES)
    at_top = [c for c in calls if c[0] == top]
    assert carried.refine == top
    assert at_top[:2] == [(top, loosest, False), (top, REFERENCE_TOL, True)], at_top
    assert at_top.count((top, loosest, False)) == 1      # the tolerance step reused it
    calls.clear()
    monkeypatch.setattr(areal, "top_rung_needed", lambda *args: False)
    nested = pilot(budget_db=0.05)
    assert [c for c in calls if c[0] == top][0] == (top, REFERENCE_TOL, False)
    assert (nested.refine, nested.tol) == (carried.refine, carried.tol)
    for model in areal.MODELS:
        np.testing.assert_allclose(carried.level_error_db[model], nested.level_error_db[model], atol=1e-3)


def test_a_budget_a_coarser_rung_may_meet_keeps_the_nested_reference(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[tuple[float, bool]] = []
    real = surface_model.contact_surface_many

    def counting(tiles, dx, dy=None, **kwargs):
        calls.append((kwargs["tol"], kwargs.get("initial_pressure") is not None))
        return real(tiles, dx, dy, **kwargs)

    monkeypatch.setattr(areal, "contact_surface_many", counting)
    pilot(budget_db=100.0)
    assert not any(started for _, started in calls)


@pytest.mark.parametrize(("step", "needed"), [(0.1, False), (0.26, False), (0.27, True), (3.0, True)])
def test_the_finest_rung_is_needed_when_even_a_fast_shrink_leaves_the_rung_below_over_budget(
        step: float, needed: bool) -> None:
    # the rung below states at least 1.5 x 2 x step / 4 = 0.75 step with the window factor
    assert areal.top_rung_needed(step, areal.WINDOW_FACTOR, 0.2) is needed
