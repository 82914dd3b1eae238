"""The error budget (issue 15): 5-smooth sizes, the convergence study and the pilot's choice.

Accuracy is judged against a much finer solve: every segment of the run, its readings joined by
straight lines (the road the samples describe, the model-grid issue: interpolated here with numpy's
``interp``, not the package's own refinement) on a grid ``truth_refine`` times finer, solved at tol
1e-10. Texture levels are judged against the file's own segments.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roads import job_road
from roadtex.budget import (
    DEFAULT_ERROR_BUDGET_DB,
    budget_bands,
    five_smooth_ladder,
    is_five_smooth,
    next_five_smooth,
    previous_five_smooth,
)
from roadtex.spectra.bands import REFERENCE_PRESSURE

TOLERANCE_DB = 0.02  # the allowance: a stated error may be below the actual one by this much


def smooth_by_trial_division(n: int) -> bool:
    factors = []
    d = 2
    while d * d <= n:
        while n % d == 0:
            factors.append(d)
            n //= d
        d += 1
    if n > 1:
        factors.append(n)
    return all(f <= 5 for f in factors)


def test_five_smooth_helpers_agree_with_trial_division() -> None:
    smooth = [n for n in range(1, 3001) if smooth_by_trial_division(n)]
    for n in range(1, 2501):
        assert is_five_smooth(n) == (n in smooth)
        nxt = next_five_smooth(n)
        assert nxt == min(m for m in smooth if m >= n)
        assert previous_five_smooth(n) == max(m for m in smooth if m <= n)
    assert next_five_smooth(13334) == 13500
    assert previous_five_smooth(13337) == 13122


def test_five_smooth_ladder_is_decreasing_smooth_and_within_bounds() -> None:
    ladder = five_smooth_ladder(13337, 1000, ratio=1.2)
    assert ladder[0] <= 13337 and ladder[-1] >= 1000
    assert all(is_five_smooth(n) for n in ladder)
    assert all(a > b for a, b in zip(ladder, ladder[1:]))
    # no gap wider than the ratio asks, up to the spacing of 5-smooth numbers (< 1.2 above 1000)
    assert all(a / b < 1.2 * 1.2 for a, b in zip(ladder, ladder[1:]))


@pytest.mark.parametrize("bad", [0, -3, 2.5, True, "8"])
def test_five_smooth_helpers_refuse_bad_numbers(bad: object) -> None:
    with pytest.raises(roadtex.InvalidInputError):
        next_five_smooth(bad)  # type: ignore[arg-type]
    with pytest.raises(roadtex.InvalidInputError):
        is_five_smooth(bad)  # type: ignore[arg-type]


def test_budget_bands_cover_the_noise_range_within_the_reported_bands() -> None:
    bands = budget_bands(0.0375e-3, 0.5)["band"].to_list()
    # 40 mm (n = 14, the longest reported in 0.5 m) to 2.5 mm (n = 26, 50 km/h at 5 kHz)
    assert bands == list(range(14, 27))
    assert 0.05 <= DEFAULT_ERROR_BUDGET_DB <= 0.2


def levels(heights: np.ndarray, dx: float, moduli: np.ndarray, tol: float) -> np.ndarray:
    """(3 kinds, segments * moduli, bands) texture, enveloped, pressure levels; texture repeated per modulus."""
    n = heights.shape[0]
    batch = roadtex.contact_many(heights, dx, moduli, 2e5, tol=tol, warm_start=True, raise_on_nonconvergence=False)
    texture = roadtex.band_levels(heights, dx, periodic=True)
    env = roadtex.band_levels(batch.envelope.reshape(n * moduli.size, -1), dx, periodic=True)
    pr = roadtex.band_levels(batch.pressure.reshape(n * moduli.size, -1), dx, periodic=True,
                             reference=REFERENCE_PRESSURE)
    return texture.bands, np.stack([np.repeat(texture.levels, moduli.size, axis=0), env.levels, pr.levels])


def by_band(bands: pl.DataFrame, values: np.ndarray) -> dict[int, np.ndarray]:
    """Band number -> (kinds, rows) levels, for the bands reported in ``bands``."""
    return {b: values[:, :, i] for i, (b, ok) in enumerate(zip(bands["band"].to_list(), bands["reported"].to_list()))
            if ok}


def actual_errors(profile: roadtex.Profile, dx: float, tol: float, moduli: np.ndarray, segment_length: float,
                  truth_refine: int, refine: int = 1) -> dict[int, float]:
    """Band -> worst |level - converged level| over every segment, modulus and level kind of the run,
    for the setting (dx, refine, tol): texture levels at dx, the contact model's on dx / refine."""
    fine = profile.conditioned(spike_alpha=None).segments(segment_length)
    texture_bands, texture_ref = levels(fine.heights, fine.dx, moduli, 1e-10)
    truth_bands, truth = levels(job_road(fine.heights, truth_refine), fine.dx / truth_refine, moduli, 1e-10)
    coarse = profile.conditioned(dx=dx, spike_alpha=None).segments(segment_length)
    assert len(coarse) == len(fine)
    coarse_bands, coarse_levels = levels(coarse.heights, coarse.dx, moduli, tol)
    model_bands, model_levels = levels(job_road(coarse.heights, refine), coarse.dx / refine, moduli, tol)
    reference, texture = by_band(texture_bands, texture_ref), by_band(coarse_bands, coarse_levels)
    converged, model = by_band(truth_bands, truth), by_band(model_bands, model_levels)
    out = {}
    for band in reference:
        if band in texture:
            out[band] = max(float(np.max(np.abs(texture[band][0] - reference[band][0]))),
                            float(np.max(np.abs(model[band][1:] - converged[band][1:]))))
    return out


def check_choice(choice: roadtex.BudgetChoice, actual: dict[int, float], *, within: bool) -> None:
    assert choice.budget_bands and set(choice.budget_bands) <= set(actual)
    for band, error in actual.items():
        stated = choice.band_error_db[band]
        assert stated >= error - TOLERANCE_DB, (band, stated, error)
        if within and band in choice.budget_bands:
            assert error <= choice.budget_db, (band, error)
    if within:
        assert choice.within_budget and choice.worst_error_db <= choice.budget_db
    assert choice.worst_error_db == pytest.approx(max(choice.band_error_db[b] for b in choice.budget_bands))


@pytest.fixture(scope="module")
def asphalt() -> roadtex.Profile:
    # 0.5 m of dense asphalt at 0.02 mm: five 0.1 m segments of 5,000 points (bands 8 mm to 0.05 mm).
    return roadtex.synthetic_pavement("dense_asphalt", 0.5, 0.02e-3, seed=3)


MODULI = np.array([2.5e6, 1e7])


@pytest.mark.parametrize(("kind", "budget"), [("dense_asphalt", 0.3), ("cement_concrete", 0.5)])
def test_synthetic_choice_meets_the_budget_and_states_its_error(kind: str, budget: float) -> None:
    profile = roadtex.synthetic_pavement(kind, 0.5, 0.02e-3, seed=3)
    choice = roadtex.choose_setting(profile, youngs_moduli=MODULI, mean_pressure=2e5, segment_length=0.1,
                                    budget_db=budget)
    assert not choice.forced and choice.seconds_per_metre > 0 and choice.finest_seconds_per_metre > 0
    assert choice.points < 5000  # a coarser setting than the file's was found within the budget
    actual = actual_errors(profile, choice.dx, choice.tol, MODULI, 0.1, truth_refine=16, refine=choice.refine)
    check_choice(choice, actual, within=True)


def test_an_unreachable_budget_runs_near_the_floor_and_says_so(asphalt: roadtex.Profile) -> None:
    # on its own 0.02 mm grid (no finer model grid allowed) this profile's levels are up to 0.006 dB
    # from the converged answer (k = 16; issue 39's estimate states 0.0062): 0.002 dB is out of reach
    choice = roadtex.choose_setting(asphalt, youngs_moduli=MODULI, mean_pressure=2e5, segment_length=0.1,
                                    budget_db=0.002, refine_candidates=[1])
    assert not choice.within_budget and choice.worst_error_db > 0.002 and choice.refine == 1
    # the cheapest setting within 5 % (and 0.01 dB) of the smallest error evaluated, not the dearest
    worst = (choice.study.filter(pl.col("in_budget") & (pl.col("refine") == 1))
             .group_by("dx", "refine", "tol").agg(pl.col("level_error_db").max()))
    floor = worst["level_error_db"].min()
    assert choice.worst_error_db <= 1.05 * floor + 0.01
    assert choice.points == 5000
    actual = actual_errors(asphalt, choice.dx, choice.tol, MODULI, 0.1, truth_refine=16, refine=choice.refine)
    check_choice(choice, actual, within=False)


def test_forced_settings_get_honest_estimates(asphalt: roadtex.Profile) -> None:
    choice = roadtex.choose_setting(asphalt, youngs_moduli=MODULI, mean_pressure=2e5, segment_length=0.1,
                                    forced_dx=0.2e-3, forced_tol=1e-4)
    assert choice.forced and choice.dx == pytest.approx(0.2e-3) and choice.tol == 1e-4
    assert choice.points == 500 and np.isfinite(choice.worst_error_db)
    assert set(choice.study["dx"].unique().round(12).to_list()) == {round(0.2e-3, 12), round(asphalt.dx, 12)}
    actual = actual_errors(asphalt, choice.dx, choice.tol, MODULI, 0.1, truth_refine=16, refine=choice.refine)
    check_choice(choice, actual, within=False)


def test_convergence_study_table(asphalt: roadtex.Profile) -> None:
    dxs = [asphalt.dx, 0.1 / 1600, 0.1 / 200]
    study = roadtex.convergence_study(asphalt, youngs_modulus=2.5e6, mean_pressure=2e5, segment_length=0.1,
                                      dx_candidates=dxs, tol_candidates=[1e-6, 1e-10], n_segments=2,
                                      refine_candidates=[1])
    reported = roadtex.band_table(asphalt.dx, 0.1).filter(pl.col("reported"))["band"].to_list()
    assert study.height == len(dxs) * 2 * len(reported)
    assert sorted(study["points"].unique().to_list()) == [200, 1600, 5000]
    # the data's own grid at tol 1e-10: no texture error, only the model grid's against the reference's
    own = study.filter((pl.col("points") == 5000) & (pl.col("tol") == 1e-10))
    assert own.height == len(reported) and (own["texture_error_db"] == 0).all() and (own["refine"] == 1).all()
    assert not study["reference"].any()   # the reference (a finer model grid) is not among the candidates
    assert set(study.filter(pl.col("in_budget"))["band"].to_list()) == set(budget_bands(asphalt.dx, 0.1)["band"])
    # the 0.4 mm band (n = 34) needs dx <= 0.16 mm: not reported at 0.5 mm
    coarse = study.filter((pl.col("points") == 200) & (pl.col("band") == 34))["level_error_db"].to_numpy()
    assert coarse.size == 2 and np.isinf(coarse).all()
    assert (study["pilot_segments"] == 2).all()
    # the data's own grid's estimate holds against a far finer solve of the pilot's segments (the
    # first and last of five; 0.3.0 asserted here that a maximum is at least one of its terms)
    segments = asphalt.finished(dx=None).segments(0.1)
    pilot = segments.heights[[0, -1]]
    levels = {}
    for k in (1, 16):
        batch = roadtex.contact_many(job_road(pilot, k), asphalt.dx / k, [2.5e6], 2e5, tol=1e-10)
        table = roadtex.band_levels(batch.envelope.reshape(2, -1), asphalt.dx / k, periodic=True)
        levels[k] = dict(zip(table.bands["band"].to_list(), table.levels.T))
    checked = 0
    for row in own.filter(pl.col("in_budget")).iter_rows(named=True):
        actual = float(np.max(np.abs(levels[1][row["band"]] - levels[16][row["band"]])))
        assert actual <= row["enveloped_error_db"], (row["band"], actual, row["enveloped_error_db"])
        checked += 1
    assert checked >= 5


def test_bad_inputs_are_refused(asphalt: roadtex.Profile) -> None:
    good = dict(youngs_moduli=MODULI, mean_pressure=2e5, segment_length=0.1)
    for change in ({"budget_db": -0.1}, {"budget_db": float("nan")}, {"youngs_moduli": []},
                   {"youngs_moduli": [-1.0]}, {"mean_pressure": 0.0}, {"segment_length": 2.0},
                   {"forced_dx": -1e-4}, {"forced_tol": 0.0}, {"tol_candidates": []}, {"n_segments": 0},
                   {"band_kind": "fifth_octave"}, {"dx_candidates": [0.0]}):
        with pytest.raises(roadtex.InvalidInputError):
            roadtex.choose_setting(asphalt, **{**good, **change})
    with pytest.raises(roadtex.InvalidInputError):
        roadtex.choose_setting("not a profile", **good)  # type: ignore[arg-type]
    with pytest.raises(roadtex.InvalidInputError):
        roadtex.convergence_study([], youngs_modulus=2.5e6, mean_pressure=2e5)


def test_captif_choice_meets_the_budget_against_a_three_times_finer_solve(captif_dir: Path) -> None:
    profile = roadtex.read_profile(captif_dir / "20211011_aylesbury_dec_station_0.dat")
    moduli = np.array([2.5e6])
    choice = roadtex.choose_setting(profile, youngs_moduli=moduli, mean_pressure=2e5)
    actual = actual_errors(profile, choice.dx, choice.tol, moduli, 0.5, truth_refine=6, refine=choice.refine)
    check_choice(choice, actual, within=True)


def test_one_pilot_for_a_group_of_runs() -> None:
    runs = [roadtex.synthetic_pavement("dense_asphalt", 0.3, 0.05e-3, seed=s) for s in (4, 5)]
    study = roadtex.convergence_study(runs, youngs_modulus=2.5e6, mean_pressure=2e5, segment_length=0.1,
                                      dx_candidates=[0.05e-3, 0.1 / 1000], tol_candidates=[1e-6], n_segments=2,
                                      include_reference_error=False)
    # 2 pilot segments for the group (its first and last); without the reference's own error, the
    # file's dx at tol 1e-6 differs from the reference only by the solver tolerance: a tiny error
    assert (study["pilot_segments"] == 2).all()
    assert (study.filter(pl.col("points") == 2000)["level_error_db"] < 1e-3).all()
    with pytest.raises(roadtex.InvalidInputError):
        roadtex.convergence_study([runs[0], roadtex.synthetic_pavement("dense_asphalt", 0.3, 0.1e-3)],
                                  youngs_modulus=2.5e6, mean_pressure=2e5, segment_length=0.1)


def test_the_search_bisects_the_candidate_intervals(asphalt: roadtex.Profile) -> None:
    # The pilot bisects the candidate dx: it solves about log2 of them, and the interval it keeps
    # is within the budget while the next coarser candidate was solved and was not.
    budget = 0.3
    choice = roadtex.choose_setting(asphalt, youngs_moduli=MODULI, mean_pressure=2e5, segment_length=0.1,
                                    budget_db=budget)
    study = choice.study.filter(pl.col("in_budget"))
    ladder = sorted(roadtex.convergence_study(asphalt, youngs_modulus=MODULI, mean_pressure=2e5, segment_length=0.1,
                                              tol_candidates=[1e-4], n_segments=1, include_reference_error=False)
                    ["dx"].unique().to_list(), reverse=True)   # every candidate dx, coarse first
    evaluated = sorted(study["dx"].unique().to_list(), reverse=True)
    assert len(ladder) >= 8
    assert len(evaluated) <= int(np.ceil(np.log2(len(ladder)))) + 2 < len(ladder)
    worst = study.group_by("dx", "tol").agg(pl.col("level_error_db").max())  # per setting, over bands
    best = worst.group_by("dx").agg(pl.col("level_error_db").min())          # best tol per dx
    best_per_dx = dict(zip(best["dx"].to_list(), best["level_error_db"].to_list()))
    assert choice.within_budget and best_per_dx[choice.dx] <= budget
    position = min(range(len(ladder)), key=lambda i: abs(ladder[i] - choice.dx))
    if position > 0:  # the next coarser candidate was solved and missed the budget at every tol tried
        coarser = min(best_per_dx, key=lambda dx: abs(dx - ladder[position - 1]))
        assert coarser == pytest.approx(ladder[position - 1]) and best_per_dx[coarser] > budget
