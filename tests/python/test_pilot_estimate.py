"""The line pilot's error estimate and size (issue 39): one Richardson rule, the stated error never
below the actual one against k = 32, the smallest k within the budget where the pilot sees the whole
run, no solves beyond the reference's own grid on data already fine.

The actual errors are measured here independently of the package's refinement: every segment of the
run joined by straight lines with numpy's ``interp`` and solved on k = 32 at tol 1e-10.
"""

from __future__ import annotations

import functools

import numpy as np
import polars as pl
import pytest

import roadtex
import roadtex.budget.pilot as pilot_module
from roads import job_road
from roadtex.budget import candidates, study
from roadtex.budget.study import (
    MAX_ORDER,
    MEASURED,
    MIN_SHRINK,
    NOT_CONVERGING,
    NOT_MEASURED,
    REFINE_LADDER,
    SPREAD_MAX_POINTS,
    reference_converged,
    richardson,
)
from roadtex.spectra.bands import REFERENCE_PRESSURE

TRUTH_REFINE = 32
MODULI = np.array([2e6, 1e7])
SEGMENT = 0.5


def test_richardson_keeps_the_factor_a_low_order_needs() -> None:
    last = np.full((2, 3), 0.1)
    # order 0.5: the differences shrink sqrt(2) times per halving; the error left is last / (sqrt 2 - 1)
    error, notes = richardson([last * np.sqrt(2.0), last])
    np.testing.assert_allclose(error, 0.1 / (np.sqrt(2.0) - 1.0))
    assert (notes == MEASURED).all()
    # a fast shrink is capped at the largest order trusted
    error, _ = richardson([last * 16.0, last])
    np.testing.assert_allclose(error, 0.1 / (2.0 ** MAX_ORDER - 1.0))


def test_richardson_flags_a_sequence_that_does_not_shrink() -> None:
    last = np.array([[0.1, 0.1], [0.1, 5e-4]])
    error, notes = richardson([np.array([[0.09, 0.2], [0.1, 6e-4]]), last])
    assert notes[0, 0] == NOT_CONVERGING and notes[1, 0] == NOT_CONVERGING   # grew, or did not shrink
    assert notes[0, 1] == MEASURED                                          # shrank twice
    assert notes[1, 1] == MEASURED                                          # below the solver's noise
    assert error[0, 0] == pytest.approx(0.1 / (MIN_SHRINK - 1.0))
    error, notes = richardson([last])                                       # one halving: order unknown
    assert notes[0, 0] == NOT_MEASURED and error[0, 0] == pytest.approx(0.1 / (MIN_SHRINK - 1.0))


def levels(heights: np.ndarray, dx: float, tol: float) -> dict[int, np.ndarray]:
    """Band -> levels (2 kinds, segments x moduli) of the segments solved as given."""
    n = heights.shape[0] * MODULI.size
    batch = roadtex.contact_many(heights, dx, MODULI, 2e5, tol=tol, warm_start=True, raise_on_nonconvergence=False)
    env = roadtex.band_levels(batch.envelope.reshape(n, -1), dx, periodic=True)
    pr = roadtex.band_levels(batch.pressure.reshape(n, -1), dx, periodic=True, reference=REFERENCE_PRESSURE)
    return {b: np.stack([env.levels[:, j], pr.levels[:, j]]) for j, b in enumerate(env.bands["band"].to_list())}


@functools.cache
def benched(length: float) -> tuple[roadtex.BudgetChoice, dict[int, np.ndarray], np.ndarray, float]:
    """Porous asphalt at 1 mm (the sampling agencies hold, where the data's own grid is off by dB and
    the pilot must refine; benches/pilot_calibration.py), ``length`` m of 0.5 m segments: the pilot's
    choice, the k = 32 levels of every segment, the segments and their interval."""
    profile = roadtex.synthetic_pavement("porous_asphalt", length, 1e-3, seed=7)
    choice = roadtex.choose_setting(profile, youngs_moduli=MODULI, mean_pressure=2e5, segment_length=SEGMENT,
                                    interpolants=False)
    data = profile.conditioned(spike_alpha=None).segments(SEGMENT)
    truth = levels(job_road(data.heights, TRUTH_REFINE), data.dx / TRUTH_REFINE, 1e-10)
    return choice, truth, data.heights, data.dx


def worst_actual(choice: roadtex.BudgetChoice, truth: dict[int, np.ndarray], heights: np.ndarray, dx: float,
                 refine: int) -> dict[int, float]:
    """Band -> worst |level - level at k = 32| over segments, moduli and kinds at (refine, choice.tol)."""
    model = levels(job_road(heights, refine), dx / refine, choice.tol)
    return {b: float(np.max(np.abs(model[b] - truth[b]))) for b in choice.band_error_db
            if np.isfinite(choice.band_error_db[b]) and b in model}


@pytest.mark.parametrize("length", [5.0, 10.0])
def test_stated_error_is_never_below_the_actual_against_k32(length: float) -> None:
    # 10 m: 20 segments, 12 in the pilot (extrapolated to the rest); 5 m: the pilot sees every segment
    choice, truth, heights, dx = benched(length)
    assert abs(choice.dx - dx) < 1e-9 * dx and choice.refine > 1 and choice.within_budget
    actual = worst_actual(choice, truth, heights, dx, choice.refine)
    assert set(choice.budget_bands) <= set(actual)
    for band, error in actual.items():
        assert choice.band_error_db[band] >= error, (band, choice.band_error_db[band], error)
    assert max(actual[b] for b in choice.budget_bands) <= choice.budget_db


def test_the_chosen_k_is_the_smallest_within_the_budget() -> None:
    # where the pilot sees every segment nothing is extrapolated: the next coarser candidate, solved
    # here independently, errs beyond the budget
    choice, truth, heights, dx = benched(5.0)
    coarser = max(k for k in REFINE_LADDER if k < choice.refine)
    actual = worst_actual(choice, truth, heights, dx, coarser)
    assert max(actual[b] for b in choice.budget_bands) > choice.budget_db, (coarser, choice.refine)


def test_one_halving_needs_a_sixteenth_of_the_budget() -> None:
    # one halving shows no order: factor 4, so k = 1 and 2 must agree within a sixteenth of the
    # budget for the reference to stop at K = 2 (the old rule stopped at a quarter: factor 1)
    budget_rows = np.ones(3, bool)
    assert not reference_converged([np.full((2, 3), 0.04)], budget_rows, 0.2)
    assert reference_converged([np.full((2, 3), 0.012)], budget_rows, 0.2)
    # a sequence that stopped shrinking is not converged either, however small its last step
    assert not reference_converged([np.full((2, 3), 0.05), np.full((2, 3), 0.045)], budget_rows, 0.2)


def test_fine_data_get_no_fine_tolerance_solves_and_a_spread_off_their_readings(monkeypatch: pytest.MonkeyPatch) -> None:
    # 0.025 mm: 20,000 points a 0.5 m segment; the reference refines at least once (40,000 points),
    # the tol effect stays within SPREAD_MAX_POINTS; the interpolants' spread, whose grid within it
    # would be the readings' own (k = 1: there the two roads are the same points, the spread nil),
    # is solved for both roads off the readings, on the next 5-smooth count above 2 N
    profile = roadtex.synthetic_pavement("dense_asphalt", 1.0, 0.025e-3, seed=2)
    solved: list[tuple[str, str, float, int]] = []

    def counting(where: str, original):
        def solve(pilot, heights, dx, tol, refine=1, interpolant=None, **more):
            points = more.get("points") or heights.shape[1] * refine
            solved.append((where, interpolant or pilot.interpolant, tol, points))
            return original(pilot, heights, dx, tol, refine, interpolant, **more)
        return solve

    tolerance: list[int] = []   # the rungs the tolerance effect is measured on (its solve may be a candidate's)
    measure = pilot_module.tolerance_effect

    def measuring(pilot, tol, k=None):
        tolerance.append(k * pilot.points)
        return measure(pilot, tol, k)

    # the candidates' own solves (resampled data, off-grid rungs) are made in roadtex.budget.candidates
    monkeypatch.setattr(study, "solve_levels", counting("study", study.solve_levels))
    monkeypatch.setattr(candidates, "solve_levels", counting("candidates", candidates.solve_levels))
    monkeypatch.setattr(pilot_module, "tolerance_effect", measuring)
    choice = roadtex.choose_setting(profile, youngs_moduli=MODULI, mean_pressure=2e5, segment_length=SEGMENT)
    assert choice.reference_refine >= 2 and max(n for *_, n in solved) >= 40000
    spread_grid = study.next_five_smooth(2 * 20000 + 1)
    assert spread_grid % 20000 != 0
    spread = {(road, n) for _, road, tol, n in solved if tol == study.SPREAD_TOL and n == spread_grid}
    assert spread == {("linear", spread_grid), ("pchip", spread_grid)}   # the default pchip road against the linear one
    assert {tol for _, road, tol, _ in solved if road == "linear"} == {study.SPREAD_TOL}
    assert not [n for _, road, _, n in solved if road == "linear" and n != spread_grid]
    assert max(choice.interpolant_spread_db[b] for b in choice.budget_bands) > 0.0
    assert tolerance and max(tolerance) <= SPREAD_MAX_POINTS
    # every loose solve of the pilot segments is made once (a candidate and the tolerance effect share it)
    loose = [(tol, n) for _, interpolant, tol, n in solved if interpolant != "linear" and tol != study.REFERENCE_TOL]
    assert len(loose) == len(set(loose)), loose


def test_the_tolerance_effect_is_measured_only_for_a_miss_on_the_coarsest_rung_as_fine_as_it(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """What a tighter tol can gain is measured when a candidate misses the budget at the loosest
    tol, once per rung, on the coarsest rung of the reference whose model interval is at least as
    fine as that candidate's (it bounds every coarser grid); one candidate tol: never."""
    measured: list[int] = []
    original = pilot_module.tolerance_effect

    def spy(pilot, tol, k=None):
        measured.append(k)
        return original(pilot, tol, k)

    solves: list[tuple[float, float, int]] = []

    def counting(solve):
        def counted(pilot, heights, dx, tol, refine=1, interpolant=None, **starts):
            if interpolant is None and tol != study.REFERENCE_TOL:
                solves.append((round(dx, 12), tol, refine))
            return solve(pilot, heights, dx, tol, refine, interpolant, **starts)
        return counted

    monkeypatch.setattr(pilot_module, "tolerance_effect", spy)
    monkeypatch.setattr(study, "solve_levels", counting(study.solve_levels))
    monkeypatch.setattr(candidates, "solve_levels", counting(candidates.solve_levels))
    profile = roadtex.synthetic_pavement("cement_concrete", 2.0, 0.5e-3, seed=6)
    choice = roadtex.choose_setting(profile, youngs_moduli=MODULI, mean_pressure=2e5, segment_length=SEGMENT,
                                    interpolants=False)
    study_rows = choice.study.filter(~pl.col("reference"))
    loosest = study_rows["tol"].max()
    missed = study_rows.filter((pl.col("tol") == loosest) & pl.col("in_budget")).group_by("dx", "refine").agg(
        pl.col("level_error_db").max()).filter(pl.col("level_error_db") > choice.budget_db)
    # the reference's rungs: the file's grid halved up to its K (model grids within SPREAD_MAX_POINTS)
    rungs = [2 ** i for i in range(6) if 2 ** i <= choice.reference_refine]
    needed = {next(r for r in rungs if r >= k) for k in missed["refine"].to_list() if k <= rungs[-1]}
    assert len(measured) == len(set(measured)) and set(measured) <= needed, (measured, needed)
    assert missed.height == 0 or measured, "a candidate missed at the loosest tol: its gain must be measured"
    assert measured and needed, (missed, measured)   # this road has misses (else the test shows nothing)
    assert all(k < choice.reference_refine for k in measured) or choice.reference_refine <= 2, (measured, choice)
    # every loose solve of the pilot segments is made once (a candidate on a rung measured shares it)
    assert len(solves) == len(set(solves)), solves
    measured.clear()
    roadtex.choose_setting(profile, youngs_moduli=MODULI, mean_pressure=2e5, segment_length=SEGMENT,
                           interpolants=False, tol_candidates=[1e-3])
    assert measured == []


def prime_road(points: int, seed: int) -> roadtex.Profile:
    """5 m of dense asphalt whose 0.5 m segments hold ``points`` readings (a prime: not 5-smooth)."""
    return roadtex.synthetic_pavement("dense_asphalt", 5.0, SEGMENT / points, seed=seed)


def actual_at(profile: roadtex.Profile, choice: roadtex.BudgetChoice, truth: dict[int, np.ndarray]) -> dict[int, float]:
    """Band -> worst |level - truth| over segments, moduli and kinds of the job's setting ``choice``
    (the data at choice.dx, refined choice.refine times, at choice.tol), solved here."""
    run = profile.conditioned(spike_alpha=None, dx=choice.dx).segments(SEGMENT)
    model = levels(job_road(run.heights, choice.refine), run.dx / choice.refine, choice.tol)
    return {b: float(np.max(np.abs(model[b] - truth[b]))) for b in choice.budget_bands}


def truth_of(profile: roadtex.Profile) -> dict[int, np.ndarray]:
    """The k = 32 levels of every segment on the data's own grid (tol 1e-10)."""
    data = profile.conditioned(spike_alpha=None).segments(SEGMENT)
    return levels(job_road(data.heights, TRUTH_REFINE), data.dx / TRUTH_REFINE, 1e-10)


def test_a_reference_off_the_data_grid_where_its_points_are_not_fft_friendly(monkeypatch: pytest.MonkeyPatch) -> None:
    # 0.5 m segments of 1,009 readings (a prime, like CAPTIF's 13,337): the reference's rungs, its
    # spread's and its tolerance effect's solves are the same road on 1,024 k points; its statements
    # still cover the actual error against k = 32 on the data's own grid, solved here independently;
    # candidates at the file's dx are solved on its own grid, 1,009 k, as a job solves them
    profile = prime_road(1009, seed=4)
    grids: list[tuple[str, float, int]] = []

    def counting(solve):
        def counted(pilot, heights, dx, tol, refine=1, interpolant=None, **more):
            grids.append((interpolant or pilot.interpolant, tol, more.get("points") or heights.shape[1] * refine))
            return solve(pilot, heights, dx, tol, refine, interpolant, **more)
        return counted

    monkeypatch.setattr(study, "solve_levels", counting(study.solve_levels))
    monkeypatch.setattr(candidates, "solve_levels", counting(candidates.solve_levels))
    choice = roadtex.choose_setting(profile, youngs_moduli=MODULI, mean_pressure=2e5, segment_length=SEGMENT)
    rungs = [1024 * 2 ** i for i in range(6) if 2 ** i <= choice.reference_refine]
    reference_solves = {n for road, tol, n in grids if road == "pchip" and tol == study.REFERENCE_TOL}
    assert choice.reference_refine >= 2 and set(rungs) <= reference_solves
    assert {n for road, _, n in grids if road == "linear"} <= set(rungs)   # the spread on a rung's grid
    loose = {n for road, tol, n in grids if road == "pchip" and tol != study.REFERENCE_TOL}
    assert any(n % 1009 == 0 for n in loose)   # a candidate at the file's dx, on its own grid
    assert not any(n % 1009 == 0 and n % 1024 == 0 for n in loose)
    reference = choice.study.filter(pl.col("reference"))
    assert reference["points"].unique().to_list() == [1024] and not reference["choosable"].any()
    assert reference["model_dx"].unique().to_list() == [pytest.approx(SEGMENT / (1024 * choice.reference_refine))]
    assert choice.study.filter(~pl.col("reference"))["choosable"].all()
    # the chosen setting is one a job can run: the data (or the data resampled) refined k times
    assert choice.points != 1024 and choice.within_budget
    truth = truth_of(profile)
    for band, actual in actual_at(profile, choice, truth).items():
        assert choice.band_error_db[band] >= actual, (band, choice.band_error_db[band], actual)


def test_an_off_grid_reference_is_never_the_setting_chosen() -> None:
    # 499 readings a 0.5 m segment: the reference's rungs are 500 k points, 1 mm apart at k = 1,
    # the very grid of a 1 mm candidate; forced there (1 mm, k = 16, tol 1e-6), the statement is the
    # candidate's (the data averaged to 1 mm, refined 16 times), not the reference's own error
    profile = prime_road(499, seed=5)
    truth = truth_of(profile)
    forced = roadtex.choose_setting(profile, youngs_moduli=MODULI, mean_pressure=2e5, segment_length=SEGMENT,
                                    interpolants=False, forced_dx=1e-3, forced_refine=16, forced_tol=1e-6)
    assert forced.points == 500 and forced.refine == 16
    assert len(forced.budget_bands) == len(set(forced.budget_bands))
    for band, actual in actual_at(profile, forced, truth).items():
        assert forced.band_error_db[band] >= actual, (band, forced.band_error_db[band], actual)
    # a budget nothing meets: the cheapest setting near the floor, never the reference's own rows
    floor = roadtex.choose_setting(profile, youngs_moduli=MODULI, mean_pressure=2e5, segment_length=SEGMENT,
                                   interpolants=False, budget_db=1e-4)
    assert not floor.within_budget
    reference = floor.study.filter(pl.col("reference"))
    assert not reference["choosable"].any() and reference["level_error_db"].max() < floor.worst_error_db
    # without a reference error the reference is the data's own grid, 499 points
    table = roadtex.convergence_study(profile, youngs_modulus=MODULI, mean_pressure=2e5, segment_length=SEGMENT,
                                      include_reference_error=False, refine_candidates=[1, 2])
    reference = table.filter(pl.col("reference"))
    assert reference["points"].unique().to_list() == [499] and reference["refine"].unique().to_list() == [1]
    assert reference["choosable"].all()
