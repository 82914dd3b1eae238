"""The pilot of a run: the cheapest (dx, k, tol) whose estimated level errors stay within the budget.

:func:`choose_setting` builds the reference of :mod:`roadtex.budget.study` on a few pilot segments
(the data's grid refined until converged), then bisects the candidate model grids (the data
resampled coarser, then the data's grid refined k times: :func:`roadtex.budget.candidates.default_settings`)
from the coarsest (cheapest) to the finest for the coarsest one within the budget in every budget
band, each at the loosest tol and then at tighter ones only while the miss is smaller than what a
tighter tol can gain (see :func:`tolerance_effect`).
When none is (``within_budget`` False: the data's sampling cannot meet the budget), it keeps the
cheapest setting whose worst error is within 5 % (and 0.01 dB) of the smallest one evaluated.
Forced settings (``forced_dx``, ``forced_tol``) restrict the search to them and are still estimated.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
import polars as pl

from roadtex._checks import positive
from roadtex.budget.candidates import (
    as_frame,
    candidate_rows,
    check_candidates,
    default_settings,
    reference_rows,
    rung_levels,
)
from roadtex.budget.noise import DEFAULT_ERROR_BUDGET_DB
from roadtex.budget.study import (
    DEFAULT_PILOT_SEGMENTS,
    DEFAULT_TOLERANCES,
    PILOT_SPREAD_FACTOR,
    REFINE_LADDER,
    SPREAD_MAX_POINTS,
    Pilot,
    build_pilot,
    run_extreme,
)
from roadtex.models.grid import DEFAULT_INTERPOLANT, check_refine
from roadtex.profiles.profile import Profile


@dataclass(frozen=True)
class BudgetChoice:
    """The setting a pilot chose, with its error estimates. All values SI.

    Attributes:
        dx: sampling interval to process the run with (m); ``Profile.conditioned(dx=...)``.
        refine: the model grid's refinement k (the contact model solved every ``dx / k``).
        tol: solver tolerance to process the run with.
        points: points per segment at ``dx`` (the model has ``points * refine``).
        budget_db: the budget (dB) the choice was made for.
        within_budget: whether ``worst_error_db`` <= ``budget_db``.
        band_error_db: band number -> upper estimate (dB) of the numerical error of that band's
            levels at (dx, tol): worst over segments, moduli and the three level kinds (texture,
            enveloped, pressure); every band reported at the file's dx, budget bands or not
            (inf where ``dx`` is too coarse to report the band).
        budget_bands: the band numbers the budget applies to (see :mod:`roadtex.budget.noise`).
        worst_error_db: the largest ``band_error_db`` over the budget bands (dB).
        seconds_per_metre: measured solve time at (dx, tol), every modulus, per metre of road (s/m).
        finest_seconds_per_metre: the same at the reference (the file's road K times finer, the reference tol) (s/m).
        pilot_seconds: wall time of the whole pilot (s).
        forced: whether dx or tol was forced.
        study: the rows of :func:`roadtex.convergence_study` the pilot evaluated.
        reference_refine: K, the refinement of the pilot's reference (its converged answer).
        interpolant_spread_db: band number -> the largest difference (dB) between the converged
            enveloped and pressure levels of the job's road and those of the other interpolants:
            what the data's sampling cannot tell (not a numerical error); empty when not measured.
    """

    dx: float
    refine: int
    tol: float
    points: int
    budget_db: float
    within_budget: bool
    band_error_db: dict[int, float]
    budget_bands: tuple[int, ...]
    worst_error_db: float
    seconds_per_metre: float
    finest_seconds_per_metre: float
    pilot_seconds: float
    forced: bool
    study: pl.DataFrame
    reference_refine: int = 1
    interpolant_spread_db: dict[int, float] = field(default_factory=dict)

    @property
    def model_dx(self) -> float:
        """The model grid's interval, dx / refine (m)."""
        return self.dx / self.refine

    @property
    def speedup(self) -> float:
        """finest_seconds_per_metre / seconds_per_metre: how much cheaper the run is than at the reference (the converged grid)."""
        return self.finest_seconds_per_metre / self.seconds_per_metre


Setting = tuple[float, int, float]   # (dx, refine, tol)


def setting_summary(rows: list[dict]) -> dict[Setting, tuple[float, float, float]]:
    """(dx, refine, tol) -> (worst budget-band error dB, work per metre, seconds per metre). Settings
    are compared by work (iterations x N log2 N), which the machine's load does not change."""
    out: dict[Setting, tuple[float, float, float]] = {}
    for row in rows:
        key = (row["dx"], row["refine"], row["tol"])
        worst, work, seconds = out.get(key, (0.0, row["work_per_metre"], row["seconds_per_metre"]))
        if row["in_budget"]:
            worst = max(worst, row["level_error_db"])
        out[key] = (worst, work, seconds)
    return out


def tolerance_rungs(pilot: Pilot) -> list[int]:
    """The rungs of the reference's sequence the tolerance effect may be measured on (model grids of
    at most :data:`~roadtex.budget.study.SPREAD_MAX_POINTS` a segment; the coarsest when none is)."""
    rungs = sorted(pilot.sequence)
    fitting = [k for k in rungs if pilot.rung_points(k) <= SPREAD_MAX_POINTS]
    return fitting or rungs[:1]


def tolerance_effect(pilot: Pilot, tol: float, k: int | None = None) -> tuple[float, float]:
    """How much tightening the loosest tol can lower an estimate (dB), and the finest model interval
    (m) that bound holds for.

    The tol error is measured on the pilot segments at the file's dx (on the rung's own grid where
    the rungs are not the file's grids refined, :attr:`~roadtex.budget.study.Pilot.off_grid`) on rung ``k`` of the
    reference's sequence (default: the reference's own where it is one of :func:`tolerance_rungs`,
    else the finest of them), against the same
    grid at the reference tol. The solver's criterion is a gap relative to the profile's peak-to-valley
    height, and a gap error moves a pressure by about E* gap / dx: at a fixed tol the level errors
    shrink as the model interval grows, so the tol error there bounds the gain on every coarser
    model grid (doubled for safety); finer ones get the tighter tolerances tried (bound inf).
    """
    if k is None:
        k = pilot.refine if pilot.refine in tolerance_rungs(pilot) else max(tolerance_rungs(pilot))
    levels, ok, _, _ = rung_levels(pilot, tol, k)   # the candidate (file dx, k, tol)'s solve if made and on its grid
    budget = pilot.bands["in_budget"].to_numpy() & ok
    gains = run_extreme(levels, pilot.sequence[k][0], pilot.run_rows, PILOT_SPREAD_FACTOR, pilot.sampled)[:, budget]
    return (2.0 * float(gains.max()) + 1e-3 if gains.size else float(np.inf)), pilot.rung_dx(k)


def coarsest_passing(size: int, passes: Callable[[int], bool], solved: Callable[[int], bool]) -> int:
    """The index of the coarsest of ``size`` settings (0 the coarsest) that ``passes`` (``size`` if
    none does), by bisection: assuming, as the level errors do up to noise, that a finer grid errs
    less, it evaluates about log2 of the candidates instead of all of them (on data that need the
    file's own interval, a coarse-to-fine walk solved every candidate).

    A setting already ``solved`` (the pilot made its loosest-tol solve for the tolerance effect) is
    evaluated in place of the middle when it lies in the middle half of the range left, the nearest
    the middle: it costs no solve and still splits the range. Over every monotone outcome and one or
    two solved settings among up to 13 candidates, that makes fewer solves than the plain bisection
    in 41 % of the cases and more in 3 % (tests/python/test_pilot_search.py); on the 1 km bench
    archive's cement concrete at 0.5 mm it skipped the k = 10 candidate (rung 8 measured for the
    tolerance effect), one of that pilot's four loose solves.
    """
    low, high = 0, size - 1
    while low <= high:
        middle = (low + high) // 2
        reach = (high - low) // 4
        middle = min((i for i in range(middle - reach, middle + reach + 1) if solved(i)),
                     key=lambda i: (abs(i - middle), i), default=middle)
        if passes(middle):
            high = middle - 1
        else:
            low = middle + 1
    return low


def dxs_used(rows: list[dict], dx: float) -> float:
    """The dx of the study rows nearest ``dx`` (rows carry segment_length / points)."""
    return min({r["dx"] for r in rows}, key=lambda used: abs(used - dx))


def choose_setting(profile: Profile | Sequence[Profile], *, youngs_moduli: float | Sequence[float],
                   mean_pressure: float, segment_length: float = 0.5,
                   budget_db: float = DEFAULT_ERROR_BUDGET_DB, forced_dx: float | None = None,
                   forced_tol: float | None = None, forced_refine: int | None = None, poisson: float = 0.5,
                   n_segments: int = DEFAULT_PILOT_SEGMENTS, band_kind: str = "third_octave",
                   spike_alpha: float | None = None, dx_candidates: Sequence[float] | None = None,
                   tol_candidates: Sequence[float] | None = None, max_iterations: int = 2000,
                   threads: int | None = None, include_reference_error: bool = True,
                   refine_candidates: Sequence[int] | None = None, interpolants: bool = True,
                   band_method: str = "dft", group_scale: float = 1.0,
                   interpolant: str = DEFAULT_INTERPOLANT, sampled: bool = False) -> BudgetChoice:
    """The cheapest (dx, k, tol) whose estimated level errors stay within ``budget_db`` in every budget band.

    Args:
        profile: a run as read (:func:`roadtex.read_profile`), or a sequence of runs of the same
            device and pavement (one pilot for the group: cheaper per run).
        youngs_moduli: rubber moduli E (Pa) the job solves for.
        mean_pressure: P (Pa).
        segment_length: the job's segment length (m).
        budget_db: largest numerical error (dB) allowed on any level in a budget band.
        forced_dx: process at this dx (m) whatever the budget (``--dx``); still estimated.
        forced_tol: process at this tol whatever the budget (``--tol``); still estimated.
        forced_refine: solve on a model grid this many times finer than the data whatever the
            budget (``--refine``); still estimated.
        poisson, band_kind, spike_alpha, max_iterations, threads: as in the job.
        n_segments: pilot segments, spread evenly along the run(s).
        dx_candidates, tol_candidates: override the candidate ladders (see :func:`convergence_study`).
        include_reference_error: as in :func:`convergence_study` (True: against the converged answer).
        refine_candidates: model grid refinements to try (see :func:`convergence_study`).
        interpolants: also measure what the sampling cannot tell (``interpolant_spread_db``: two
            more solves of the pilot segments on the reference grid).
        band_method: how the job computes band levels ("dft" or "filter", ``--band-method``): the
            pilot estimates the errors of the levels the job reports (the filter bank errs
            otherwise than DFT band sums: with DFT estimates the stated error was below the actual
            in 34 of 256 rows of a filter-method job).
        group_scale: how many times the rows of the pilot's runs the group it speaks for holds (the
            job's group of many runs: its errors are extrapolated to the largest of that many rows).
        interpolant: the job's road between readings (``--interpolant``,
            :data:`roadtex.models.grid.INTERPOLANTS`): every pilot solve joins the readings so, so
            that the errors stated are those of the levels the job computes.
        sampled: ``profile`` is a sample of a group of more runs, which the choice speaks for too:
            the pilot's rows are then always extrapolated, even when they are all of its runs'
            (short runs), since the other runs' largest errors are not among them.

    Returns:
        A :class:`BudgetChoice`.

    Raises:
        InvalidInputError: bad arguments, a run too short for one segment, no reported band.
    """
    started = time.perf_counter()
    budget = positive(budget_db, "budget_db", "dB")
    forced_dx_f = None if forced_dx is None else positive(forced_dx, "forced_dx", "m")
    forced_tol_f = None if forced_tol is None else positive(forced_tol, "forced_tol", "relative residual")
    forced_refine_k = None if forced_refine is None else check_refine(forced_refine, "forced_refine")
    dxs_given = check_candidates(dx_candidates, "dx_candidates")
    tols_given = check_candidates(tol_candidates, "tol_candidates")
    refines_given = None if refine_candidates is None else [check_refine(k, "refine_candidates") for k in refine_candidates]
    pilot = build_pilot(profile, youngs_moduli=youngs_moduli, mean_pressure=mean_pressure, poisson=poisson,
                        segment_length=segment_length, n_segments=n_segments, band_kind=band_kind,
                        spike_alpha=spike_alpha, max_iterations=max_iterations, threads=threads,
                        include_reference_error=include_reference_error, budget_db=budget, interpolants=interpolants,
                        band_method=band_method, group_scale=group_scale, interpolant=interpolant,
                        sampled=sampled)
    dxs = [forced_dx_f] if forced_dx_f is not None else dxs_given
    refines = [forced_refine_k] if forced_refine_k is not None else refines_given
    if forced_dx_f is not None and refines is None:   # a forced interval refined up to the reference's model grid
        refines = [k for k in REFINE_LADDER if forced_dx_f / k >= pilot.dx / pilot.refine * (1 - 1e-9)] or [1]
    settings = default_settings(pilot, dxs, refines)
    tols = sorted([forced_tol_f] if forced_tol_f is not None else (tols_given or list(DEFAULT_TOLERANCES)),
                  reverse=True)

    rows: list[dict] = []
    # What a tighter tol can gain at a model interval (dB): measured once per rung of the reference,
    # and only when a candidate misses the budget at the loosest tol, on the coarsest rung at least
    # as fine as that candidate (issue 39: the finest rung cost a second or more, on CAPTIF as
    # measured 1.7 of the pilot's 12 s, and most candidates never ask). One tol: nothing to gain.
    effects: dict[int, float] = {}

    def tighter_tol_gain(model_dx: float) -> float:
        if len(tols) < 2:
            return 0.0
        rung = next((r for r in tolerance_rungs(pilot) if pilot.dx / r <= model_dx * (1 + 1e-9)), None)
        if rung is None:   # finer than every rung measured: the tighter tolerances are tried
            return np.inf
        if rung not in effects:
            effects[rung] = tolerance_effect(pilot, tols[0], rung)[0]
        return effects[rung]

    def evaluate(setting: tuple[float, int]) -> bool:
        """Study rows at ``setting`` (dx, k), loosest tol first, tighter ones only while they can
        still help: whether a setting there is within the budget."""
        dx, k = setting
        for tol in tols:
            done = [r for r in rows if r["tol"] == tol and r["refine"] == k and abs(r["dx"] - dx) <= 1e-9 * dx]
            new = done or candidate_rows(pilot, dx, [tol], k)
            if not done:
                rows.extend(new)
            worst = max((r["level_error_db"] for r in new if r["in_budget"]), default=0.0)
            if worst <= budget:
                return True
            if worst > budget + tighter_tol_gain(dx / k):  # beyond what a tighter tol can gain
                return False
        return False

    # Bisection over the model grids, coarse (cheap) to fine (dear): see coarsest_passing.
    def solved(index: int) -> bool:
        dx, k = settings[index]
        return abs(dx - pilot.dx) <= 1e-9 * pilot.dx and (int(k), float(tols[0])) in pilot.solved

    coarsest_passing(len(settings), lambda index: evaluate(settings[index]), solved)
    if not any(r["reference"] for r in rows):  # no solve: the pilot's own reference levels
        rows.extend(reference_rows(pilot))
    forced = forced_dx_f is not None or forced_tol_f is not None or forced_refine_k is not None
    # only the candidate settings may be chosen: the reference is there for comparison only (and a
    # reference on a grid of its own, Pilot.off_grid, is no setting a job can run)
    choosable = [r for r in rows if r["choosable"]]
    allowed = {(dxs_used(choosable, dx), k) for dx, k in settings}
    summary = {key: v for key, v in setting_summary(choosable).items()
               if key[:2] in allowed and (forced_tol_f is None or key[2] == forced_tol_f)}
    within = {k: v for k, v in summary.items() if v[0] <= budget}
    if not within:
        # Out of reach (the data's own sampling cannot meet the budget): the cheapest setting whose
        # error is within 5 % (and 0.01 dB) of the smallest one evaluated, not the dearest solve.
        floor = min(v[0] for v in summary.values())
        within = {k: v for k, v in summary.items() if v[0] <= 1.05 * floor + 0.01}
    key = min(within, key=lambda k: (within[k][1], -k[0] / k[1]))
    worst, _, seconds = summary[key]
    chosen = [r for r in choosable if (r["dx"], r["refine"], r["tol"]) == key]
    spread = pilot.interpolant_spread
    return BudgetChoice(
        dx=key[0], refine=key[1], tol=key[2], points=chosen[0]["points"], budget_db=budget, within_budget=worst <= budget,
        band_error_db={r["band"]: r["level_error_db"] for r in chosen},
        budget_bands=tuple(r["band"] for r in chosen if r["in_budget"]), worst_error_db=worst,
        seconds_per_metre=seconds, finest_seconds_per_metre=pilot.seconds_per_metre,
        pilot_seconds=time.perf_counter() - started, forced=forced, study=as_frame(rows),
        reference_refine=pilot.refine,
        interpolant_spread_db={} if spread is None else
        {int(b): float(v) for b, v in zip(pilot.bands["band"].to_list(), spread)})
