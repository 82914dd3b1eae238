"""The numerical error of a surface run's levels: an areal pilot on a few of its tiles.

A surface run (3D texture) is solved on a *model grid* ``k`` times finer than the data's along and
across the road (the readings joined by the job's interpolant, monotone cubics each way by default,
:func:`roadtex.models.grid.refine_periodic_surface`), with the areal model on tiles and with the line
model (refined ``k`` times along) on rows of the
same tiles (see :mod:`roadtex.archive.surface_run`). Its levels get error estimates the way a line
run's do (:mod:`roadtex.budget.study`), and its ``k`` and solver tolerance are chosen as cheap as the
budget allows, from a few *pilot* tiles spread evenly along the run:

1. **The k ladder**: each pilot tile (and its analysed rows, for the line model) solved at the
   reference tolerance (1e-6, :data:`roadtex.budget.study.REFERENCE_TOL`) on model grids
   :data:`REFINE_LADDER` (1, 2, 4, 8) times finer each way (only ``k`` and ``2 k`` when
   ``refine`` forces ``k``), each modulus from its own nested start and the moduli in parallel
   (not chained as the job solves them: at this tolerance that is quicker, and only the answers
   count). Refining along the road alone is not enough on 1 mm surfaces: (8, 1) still errs by 4
   to 5 dB where (8, 8) errs by 0.3 dB (``benches/surface_model_grid.py``;
   docs/guide/model-grid.md, "Surface runs"). When no rung below the finest can meet the budget
   (:func:`top_rung_needed`), the finest is solved first as the job solves it at the loosest
   candidate tolerance and carried on from there to the reference tolerance (step 3 reuses it).
2. **Richardson over the ladder**: the converged answer is taken as the finest rung ``L(top)``,
   whose own error is a factor times |L(top) - L(top / 2)|: 1 / (r - 1) for the shrink r of the
   last two steps (the median over levels and bands, :func:`tail_factor`), between
   :data:`TAIL_FACTOR_MIN` (1: at least first order; the levels measured on 1 mm surfaces shrink
   2.7 to 3.3 times per halving) and :data:`TAIL_FACTOR` (2, and for a forced k, whose two rungs
   show no rate); a rung's error is |L(k) - L(top)| plus that. The cheapest rung within the
   budget in every budget band is the run's ``k`` (when none is, the cheapest within 5 % (and
   0.01 dB) of the best, as the line runs' pilot does); a forced ``k`` is estimated the same way
   against ``2 k``. A rung whose model grid of a whole tile would exceed :data:`MAX_MODEL_POINTS`
   is not chosen (it still serves as the reference).
3. **Tolerance**: the tiles solved at the chosen ``k`` at each candidate tolerance, loosest first
   (1e-3, 1e-4, 1e-6; only the given one when the job's tol was given); the difference from
   the reference at that ``k``. The first candidate within the budget is the run's.
4. **Estimate** per (model, band): the differences of the pilot rows extended to every row of the
   run (:func:`roadtex.budget.study.extreme`), the tolerance's times ``SPREAD_FACTOR``, plus the
   grid's; the larger of the enveloped and pressure estimates. Texture levels are the data's own
   (no resampling): no numerical error.

On the model grid an analysed data row is a fine row (the data row refined along the road); its
enveloped profile is that fine row, its pressure the mean over the data row's width (``dy``, the
fine rows within ``dy / 2`` of it, trapezoid-weighted): at ``k = 1`` both are the row itself, and
the pressure along a single fine row (a line through a 2-D pressure map) does not converge (5 to
7 dB off at (4, 4) against (16, 16), where the width's mean is 0.2 to 1.5 dB off).

A row of a tile in contact with the rubber at one setting and not at the other (it barely touches:
its pressure level is -inf at one) differs without bound; such rows are left out of the samples,
and no estimate covers them (their pressure levels mean little at any setting).

The pilot is bounded. On a wide tile it solves a *window*: a strip of the tile along its whole
length (the same bands) and as many rows as make :data:`AREAL_WINDOW_POINTS` points (fewer when its
finest rung would exceed :data:`AREAL_PILOT_POINTS`), across the tile's seam (:func:`pilot_window`),
its own plane removed, solved as a periodic cell as tiles are; the areal estimate comes from every
row of it (the line model's, cheap, from every analysed row). The discretisation error of a row's
levels depends on how finely the grid resolves the contact spots along it, which the strip's rows
show as the tile's do, up to :data:`WINDOW_FACTOR` (tested against the whole tile).
At most :data:`AREAL_PILOT_POINTS` points on the finest rung over all pilot tiles (fewer tiles when
windows are large); a run whose window is too large for even one is not estimated (None).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from roadtex.budget.study import REFERENCE_TOL, SPREAD_FACTOR, contact_levels, difference, extreme, solver_work
from roadtex.models.contact import contact_many
from roadtex.models.grid import (
    DEFAULT_INTERPOLANT,
    Interpolant,
    check_interpolant,
    check_refine,
    refine_periodic,
    refine_periodic_surface,
)
from roadtex.models.surface import contact_surface_many
from roadtex.spectra.bands import BandKind
from roadtex.spectra.levels import Method

#: Pilot tiles of a surface run, spread evenly along it (fewer when they are large).
AREAL_PILOT_TILES = 3

#: Largest pilot window, in points at the run's spacing: a strip of the tile as long as the tile
#: and as many rows across as make up this many points (at least :data:`MIN_WINDOW_ROWS` rows). 2^15: 32 rows (16 mm at
#: 0.5 mm) of a 0.5 m tile at 0.5 mm, the strip width checked at 1 mm (16 of 64 rows: the
#: estimates covered the whole tile's errors on 18 surfaces; docs/guide/error-budget.md, "Error budget: surface runs").
AREAL_WINDOW_POINTS = 2 ** 15

#: Fewest rows of a pilot window.
MIN_WINDOW_ROWS = 8

#: Safety factor on the areal estimate from a window instead of the whole tile: a strip is its own
#: periodic cell, whose rows err a little differently from the tile's. On 24 surfaces (3 pavements x
#: 8 seeds, 0.128 m x 64 mm tiles at 1 mm, 16-row windows) the window's estimate fell below the whole
#: tile's error by up to 0.51 dB (stated / actual 0.87) in one band of one surface; 1.5 covers that
#: with room (``benches/areal_budget.py``; measured on the data's grid, windows around the middle
#: row). On the model grid, with windows across the seam (:func:`pilot_window`), 3 such tiles (dense
#: asphalt seed 7, cement concrete 8, porous asphalt 9; k = 8) gave areal stated / actual 1.27 to 26 against
#: the whole tile solved 16 times finer each way.
WINDOW_FACTOR = 1.5

#: Largest number of points on the pilot's finest rung over all pilot windows (``top**2`` per point
#: of a window, ``top`` the ladder's finest k): the pilot's cost, about that many points solved per
#: modulus at the reference tol (the coarser rungs add a third). 2^19: a 1 mm tile 0.5 m long is piloted on
#: a 16-row window at k = 8 (the demo's 1 mm surfaces: 72 s for the three under load, against 137 s
#: with 2^20 and 32 rows; stated worst errors 0.57 to 0.93 dB against 0.59 to 0.95, both with a
#: window around the middle row).
AREAL_PILOT_POINTS = 2 ** 19

#: The model grid refinements (k along = k across) the pilot tries, cheapest first: the run's k is
#: one of them (the finest is the converged answer's stand-in, see the module). Not the line pilot's
#: ladder (roadtex.budget.study.REFINE_LADDER, 1 to 32 with 3, 5, 6, 10, 12, 20, 24 between the powers of two):
#: a surface's model grid costs k^2 points, so k = 16 on a 1 mm tile of 0.5 m x 40 mm is already
#: 5.1 million points, above MAX_MODEL_POINTS; and the surface pilot extrapolates over doublings of k.
REFINE_LADDER = (1, 2, 4, 8)

#: Largest model grid of one tile the pilot may choose (points, ``ny nx k^2``): the job solves a
#: tile whole, so a fine grid on a large tile would need gigabytes (a 0.5 m x 0.2 m tile at 0.5 mm,
#: 400,000 points, is 25.6 million at k = 8). Rungs beyond it are still solved by the pilot (on its
#: bounded windows) to estimate the chosen one's error. 4 million: the job's chunk of points.
MAX_MODEL_POINTS = 4_000_000

MODELS = ("line", "areal")

#: Richardson factor of the finest rung's own error, at most: error(top) ~ factor x |L(top) -
#: L(top / 2)|. 2 is the areal pilot's factor before the model grid (its error(h) = 3 |L(h / 2) -
#: L(h)|, 48 cases), and a forced k (two rungs: no convergence rate to read) gets it: at k = 1 on
#: 1 mm surfaces the levels are not yet converging steadily (a dense asphalt tile's band erred
#: 5.9 dB against (8, 8) where |L(1) - L(2)| was 2.6 dB: factor 1 fell 0.8 dB short).
TAIL_FACTOR = 2.0

#: The least tail factor, on a ladder whose last two steps shrank at least 2 times per halving (at
#: least first order: 1 / (2 - 1)). Per model the factor is 1 / (r - 1) for the measured shrink r,
#: the median over levels and bands of |L(top / 2) - L(top / 4)| / |L(top) - L(top / 2)| (each
#: extended to the run's rows), kept within [TAIL_FACTOR_MIN, TAIL_FACTOR]. Measured on 6 cases (3 synthetic pavements x 2
#: seeds, 1 mm, 0.128 m x 8 mm tiles, E = 1 to 10 MPa, tol 1e-10), the worst error over the budget
#: bands against (32, 32) fell 8.1, 2.7, 0.91, 0.33, 0.13 dB at k = 1, 2, 4, 8, 16: 2.7 to 3 times
#: per halving (factor 0.5 to 0.6), so 1 leaves room (``benches/surface_model_grid.py``).
TAIL_FACTOR_MIN = 1.0

#: The largest shrink per halving :func:`top_rung_needed` allows the last step of the ladder
#: (measured 2.7 to 3.3 on 1 mm surfaces, see :data:`TAIL_FACTOR_MIN`).
TOP_SHRINK_GUESS = 4.0


@dataclass(frozen=True)
class SurfaceErrors:
    """Error estimates of a surface run's levels at its chosen model grid and tol.

    Attributes:
        bands: band numbers, those reported at the run's tile length and the data's dx.
        in_budget: which of ``bands`` the budget applies to (:mod:`roadtex.budget.noise`).
        level_error_db: model ("line", "areal") -> upper estimate (dB) per band of the numerical
            error of that model's enveloped and pressure levels (the larger of the two), any row.
        work_speedup: the solver work (iterations x N log2 N, both models) at the reference
            tolerance over that at ``tol``, on the pilot tiles, both at the chosen ``refine``.
        pilot_tiles: the tiles (indices along the run) the estimate comes from.
        tol: the solver tolerance the estimates are for (the chosen one).
        refine: the model grid's refinement k the estimates are for (along and across the road:
            the model grid is (dx / k, dy / k); 1 is the data's grid).
    """

    bands: np.ndarray
    in_budget: np.ndarray
    level_error_db: dict[str, np.ndarray]
    work_speedup: float
    pilot_tiles: tuple[int, ...]
    tol: float
    refine: int = 1

    def worst_db(self) -> float:
        """The largest estimate over both models in the budget bands (dB; 0 without budget bands)."""
        return worst_in_budget(self.level_error_db, self.in_budget)


def worst_in_budget(estimates: dict[str, np.ndarray], in_budget: np.ndarray) -> float:
    """The largest of per-band ``estimates`` (model -> dB per band) in the budget bands; a
    non-finite value (no bounded sample) counts as infinite; 0 without budget bands."""
    values = [np.where(np.isfinite(e), e, np.inf)[in_budget] for e in estimates.values()]
    return float(max((v.max() for v in values if v.size), default=0.0))


def refine_ladder(refine: int | None) -> tuple[int, ...]:
    """The model grid refinements the pilot solves: :data:`REFINE_LADDER`, or ``(k, 2 k)`` for a
    forced ``k``."""
    return REFINE_LADDER if refine is None else (int(refine), 2 * int(refine))


def pilot_window(n_y: int, n_x: int, rows: np.ndarray, top: int = REFINE_LADDER[-1]) -> tuple[np.ndarray, np.ndarray]:
    """The rows of a tile (``n_y`` x ``n_x`` points, analysed ``rows``) the pilot solves: all of
    them when they fit in :data:`AREAL_WINDOW_POINTS` (and in :data:`AREAL_PILOT_POINTS` at the
    ladder's finest ``top``), else a strip of that many points (at least :data:`MIN_WINDOW_ROWS`
    rows) across the tile's seam: its last rows then its first, as the periodic tile joins them.
    The rows next to the seam err most on a model grid (the road joined across the jump from the
    last row to the first; 0.71 dB at k = 8 on a porous asphalt tile's row 0, 0.04 to 0.07 on its
    inner analysed rows), and the job's first and last analysed rows are there. Returns the
    strip's rows (indices in the tile, in the strip's order) and the positions in ``rows`` of the
    analysed rows inside it."""
    points = min(AREAL_WINDOW_POINTS, AREAL_PILOT_POINTS // top ** 2)
    count = min(n_y, max(MIN_WINDOW_ROWS, points // max(n_x, 1)))
    rows = np.asarray(rows, dtype=np.int64)
    if count >= n_y:
        return np.arange(n_y), np.arange(rows.size)
    strip = np.r_[np.arange(n_y - count // 2, n_y), np.arange(count - count // 2)]
    return strip, np.flatnonzero(np.isin(rows, strip))


def pilot_tile_indices(n_tiles: int, points_per_window: int, top: int = REFINE_LADDER[-1]) -> np.ndarray:
    """Up to :data:`AREAL_PILOT_TILES` tiles spread evenly over ``n_tiles``, as many as fit in
    :data:`AREAL_PILOT_POINTS` on the ladder's finest rung ``top`` (empty: one window does not fit)."""
    fits = AREAL_PILOT_POINTS // (top ** 2 * max(points_per_window, 1))
    count = min(AREAL_PILOT_TILES, n_tiles, fits)
    if count <= 0:
        return np.empty(0, dtype=np.int64)
    return np.unique(np.round(np.linspace(0, n_tiles - 1, count)).astype(np.int64))


def row_strips(field: np.ndarray, rows: np.ndarray, refine: int) -> np.ndarray:
    """The mean over each data row's width of a field on the model grid: (..., ny k, nx k) ->
    (..., rows, nx k), the fine rows within dy / 2 of data row ``r`` (``r k``, trapezoid-weighted,
    periodic across), so that ``refine`` = 1 gives the rows themselves (see the module)."""
    rows = np.asarray(rows, dtype=np.int64)
    if refine == 1:
        return field[..., rows, :]
    offsets = np.arange(-(refine // 2), refine // 2 + 1)
    weights = np.ones(offsets.size)
    if refine % 2 == 0:
        weights[[0, -1]] = 0.5
    weights /= weights.sum()
    n = field.shape[-2]
    total = np.zeros(field.shape[:-2] + (rows.size, field.shape[-1]))
    for offset, weight in zip(offsets, weights):
        total += weight * field[..., (rows * refine + offset) % n, :]
    return total


@dataclass(frozen=True)
class _Setup:
    moduli: np.ndarray
    mean_pressure: float
    poisson: float
    kind: BandKind
    method: Method
    max_iterations: int
    threads: int | None
    interpolant: Interpolant = DEFAULT_INTERPOLANT


def _line_levels(setup: _Setup, lines: np.ndarray, dx: float, tol: float, refine: int,
                 bands: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The line model on rows ``lines`` (rows, x) refined ``refine`` times: levels (2, rows x
    moduli, bands), reported, work."""
    fine = refine_periodic(lines, refine, setup.interpolant)
    batch = contact_many(fine, dx / refine, setup.moduli, setup.mean_pressure, poisson=setup.poisson, tol=tol,
                         max_iterations=setup.max_iterations, threads=setup.threads, warm_start=True,
                         raise_on_nonconvergence=False)
    levels, ok = contact_levels(batch.envelope, batch.pressure, dx / refine, bands, setup.kind, setup.method)
    return levels, ok, solver_work(batch.iterations, fine.shape[-1])


def _areal_levels(setup: _Setup, heights: np.ndarray, dx: float, dy: float, tol: float, rows: np.ndarray,
                  refine: int, shift: np.ndarray, bands: np.ndarray, as_the_job: bool = True,
                  initial: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """The areal model on tiles ``heights`` (tiles, ny, nx) on a model grid ``refine`` times finer
    each way; levels (2, tiles x lines x moduli, bands) along the analysed data ``rows`` (see the
    module), the envelope moved by ``shift`` (tiles, lines, nx at the data's dx, refined as the road)
    as the job moves it. ``as_the_job``: each tile's moduli chained as the job solves them, each
    from the last's answer (a candidate tolerance's error must be the job's solve's); False for the
    ladder's reference solves, whose answers are all that counts: each modulus from its own nested
    start, the moduli in parallel. At the reference tolerance the chain takes no fewer iterations
    (the demo's dense asphalt window at k = 8: 76, 73, 63, 60 chained against 76, 68, 59, 48), and
    the demo's three windows at k = 1 to 8 took 14.6 s unchained against 19.6 s chained (best of
    2; 15.3 s each rung started from the one below, prolonged). ``initial``: each problem started
    from its own pressure (tiles, moduli, ny k, nx k; Pa), unchained. Returns the levels, which
    are reported, the work and the pressures (tiles, moduli, ny k, nx k; Pa)."""
    fine = refine_periodic_surface(heights, refine, refine, setup.interpolant)
    solved = contact_surface_many(fine, dx / refine, dy / refine, youngs_modulus=setup.moduli,
                                  mean_pressure=setup.mean_pressure, poisson=setup.poisson, tol=tol,
                                  max_iterations=setup.max_iterations, threads=setup.threads,
                                  warm_start=as_the_job and initial is None, raise_on_nonconvergence=False,
                                  initial_pressure=initial)
    rows = np.asarray(rows, dtype=np.int64)
    # (tiles, moduli, lines, x) -> (tiles, lines, moduli, x)
    envelope = np.moveaxis(solved.envelope[:, :, rows * refine, :], 1, 2)
    pressure = np.moveaxis(row_strips(solved.pressure, rows, refine), 1, 2)
    envelope = envelope - refine_periodic(shift, refine, setup.interpolant)[:, :, None, :]
    levels, ok = contact_levels(envelope, pressure, dx / refine, bands, setup.kind, setup.method)
    return levels, ok, solver_work(solved.iterations, fine.shape[1] * fine.shape[2]), solved.pressure


def top_rung_needed(step_below: float, window_factor: float, budget_db: float) -> bool:
    """Whether no rung below the ladder's finest can be within ``budget_db`` (dB), judged before
    the finest is solved from the areal model's worst budget-band step ``step_below`` between the
    two rungs below it (dB, extended to the run's rows): the next step shrinks at most
    :data:`TOP_SHRINK_GUESS` times (measured 2.7 to 3.3 per halving on 1 mm surfaces), and the
    rung below the finest then states at least (1 + :data:`TAIL_FACTOR_MIN`) times that step,
    times ``window_factor``. Only the pilot's cost rides on it: when a rung below is chosen
    after all, the finest rung's job-like solve was made for nothing (its reference is right
    either way)."""
    return window_factor * (1.0 + TAIL_FACTOR_MIN) * step_below / TOP_SHRINK_GUESS > budget_db


def tail_factor(last: np.ndarray, before: np.ndarray | None) -> float:
    """The finest rung's Richardson factor from its last step ``last`` and the one ``before`` it
    (dB per (level, band), extended to the run's rows): 1 / (r - 1) for the shrink r, the median
    over levels and bands of before / last (one band's step alone is noisy: a band can shrink
    little from one halving to the next and much at the following), within
    [:data:`TAIL_FACTOR_MIN`, :data:`TAIL_FACTOR`]; :data:`TAIL_FACTOR` without a step before (a
    forced k) or where the levels do not shrink (r <= 1, or no finite ratio)."""
    if before is None:
        return TAIL_FACTOR
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = np.asarray(before) / np.asarray(last)
    ratios = ratios[np.isfinite(ratios)]
    if ratios.size == 0 or np.median(ratios) <= 1.0:
        return TAIL_FACTOR
    return float(np.clip(1.0 / (np.median(ratios) - 1.0), TAIL_FACTOR_MIN, TAIL_FACTOR))


def surface_level_errors(heights: np.ndarray, lines: np.ndarray, shift: np.ndarray, rows: np.ndarray, dx: float,
                         dy: float, *, bands: np.ndarray, in_budget: np.ndarray, run_rows: int,
                         youngs_moduli: np.ndarray, mean_pressure: float, poisson: float,
                         tols: Sequence[float], budget_db: float, band_kind: BandKind, band_method: Method,
                         max_iterations: int, threads: int | None,
                         pilot_tiles: tuple[int, ...] = (), window_factor: float = 1.0,
                         refine: int | None = None, interpolant: Interpolant = DEFAULT_INTERPOLANT,
                         tile_points: int | None = None) -> SurfaceErrors:
    """Error estimates of a surface run's levels from its pilot tiles, at the cheapest model grid
    and the loosest tolerance that need no more (see the module).

    The model grid refinements of :func:`refine_ladder` are tried cheapest first; the first whose
    worst estimate (at the reference tolerance) in the budget bands is within ``budget_db`` is
    chosen, or, when none is, the cheapest within 5 % (and 0.01 dB) of the best. Then the candidate
    tolerances ``tols`` at that grid, loosest first, the same way against the floor (the grid's
    estimate alone). One candidate (a forced ``refine`` or tol): it is estimated.

    Args:
        heights: the pilot tiles (or their windows, :func:`pilot_window`) as solved (tiles, ny,
            nx; m, plane removed), at the data's spacings.
        lines: the line model's stretches of every analysed row of the pilot tiles (tiles, lines,
            nx; m, each its line removed).
        shift: the move of those rows of the areal envelope into the line model's frame (tiles,
            rows, nx; m): each row's least-squares line.
        rows: the rows of ``heights`` whose areal levels are compared (indices in it, across the
            road; the job uses every row of the window).
        dx, dy: the data's spacings along and across the road (m).
        bands: band numbers to estimate (those the job reports); in_budget: which are budget bands.
        run_rows: rows (tiles x lines x moduli) of each model in the whole run.
        tols: candidate solver tolerances (relative residual).
        budget_db: the error budget (dB).
        youngs_moduli, mean_pressure, poisson, band_kind, band_method, max_iterations, threads: as
            the job solves and analyses the run (Pa, Pa, 1).
        pilot_tiles: the tiles' indices along the run (their count goes to the run's table).
        window_factor: multiplies the areal estimate: :data:`WINDOW_FACTOR` when ``heights`` are
            windows of the run's tiles, 1 for whole tiles.
        refine: the model grid's k (along and across), forced; None chooses it (see the module).
        interpolant: the road between readings (:data:`roadtex.models.grid.INTERPOLANTS`).
        tile_points: points of one of the run's tiles (ny nx; None: those of ``heights``): the
            rungs whose model grid of a tile exceeds :data:`MAX_MODEL_POINTS` are not chosen (1 is).

    Returns:
        A :class:`SurfaceErrors` at the chosen model grid and tolerance.
    """
    setup = _Setup(np.asarray(youngs_moduli, dtype=np.float64), mean_pressure, poisson, band_kind, band_method,
                   max_iterations, threads, check_interpolant(interpolant))
    flat = lines.reshape(-1, lines.shape[-1])
    budget_mask = np.asarray(in_budget, dtype=bool)
    ladder = refine_ladder(None if refine is None else check_refine(refine))

    def solve(model: str, tol: float, k: int, as_the_job: bool = True) -> tuple[np.ndarray, np.ndarray, float]:
        if model == "line":
            return _line_levels(setup, flat, dx, tol, k, bands)
        return _areal_levels(setup, heights, dx, dy, tol, rows, k, shift, bands, as_the_job)[:3]

    def spread(measured: np.ndarray, ok: np.ndarray) -> np.ndarray:
        """(2, bands): the differences (2, pilot rows, bands) extended to every row of the run. A
        row in contact at one setting and not at the other (its pressure level -inf at one: an
        unbounded difference) is left out of the sample (see the module)."""
        sample = np.where(ok & np.isfinite(measured), measured, np.nan)
        return extreme(np.moveaxis(sample, 1, 0), run_rows)

    scale = {"line": 1.0, "areal": window_factor}   # a window's areal estimate, scaled up as a whole
    top, below = ladder[-1], ladder[-2]
    points = int(np.prod(heights.shape[1:])) if tile_points is None else int(tile_points)
    choices = ladder[:1] if refine is not None else tuple(
        c for c in ladder if c == 1 or points * c ** 2 <= MAX_MODEL_POINTS)
    candidates = sorted(tols, reverse=True)
    solved = {model: {k: solve(model, REFERENCE_TOL, k, as_the_job=False) for k in ladder[:-1]} for model in MODELS}
    solved["line"][top] = solve("line", REFERENCE_TOL, top)
    # The finest rung is the dearest solve and, on surfaces the data leave coarse, the run's k: its
    # job-like solve at the loosest tol is then made first and carried on to the reference tol
    # (each modulus from its own answer there), a third to a half fewer iterations than the
    # reference from its nested start (the demo's three 16-row windows at k = 8: 1.1 to 1.9 s
    # against 2.0 to 2.7 s, 2026-12-02); the candidate is kept for the tolerance step below.
    kept: dict[tuple[str, float, int], tuple[np.ndarray, np.ndarray, float]] = {}
    step_below = (worst_in_budget({"areal": spread(difference(solved["areal"][below][0], solved["areal"][ladder[-3]][0]),
                                                   solved["areal"][below][1]).max(axis=0)}, budget_mask)
                  if len(ladder) >= 3 else 0.0)
    if (top in choices and candidates[0] > REFERENCE_TOL
            and top_rung_needed(step_below, window_factor, budget_db)):
        first = _areal_levels(setup, heights, dx, dy, candidates[0], rows, top, shift, bands)
        kept[("areal", candidates[0], top)] = first[:3]
        carried = _areal_levels(setup, heights, dx, dy, REFERENCE_TOL, rows, top, shift, bands, as_the_job=False,
                                initial=first[3])
        # the reference's work from the job's own start: the candidate's and the rest of the way
        solved["areal"][top] = (carried[0], carried[1], first[2] + carried[2])
    else:
        solved["areal"][top] = solve("areal", REFERENCE_TOL, top, as_the_job=False)
    # Richardson over the ladder: the finest rung stands for the converged answer, its own error
    # the tail factor x its last step; each rung's error is its distance from the finest plus that
    grid: dict[int, dict[str, np.ndarray]] = {}
    for model in MODELS:
        finest, ok_top, _ = solved[model][top]
        last = spread(difference(finest, solved[model][below][0]), ok_top)
        tail = tail_factor(last, spread(difference(solved[model][below][0], solved[model][ladder[-3]][0]), ok_top)
                           if len(ladder) >= 3 else None) * last
        for k in ladder:
            step = 0.0 if k == top else spread(difference(solved[model][k][0], finest), ok_top)
            grid.setdefault(k, {})[model] = (step + tail) * scale[model]
    worst = {k: worst_in_budget({m: grid[k][m].max(axis=0) for m in MODELS}, budget_mask) for k in ladder}
    best = min(worst[k] for k in choices)
    allowed_k = budget_db if best <= budget_db else 1.05 * best + 0.01
    k = next(c for c in choices if worst[c] <= allowed_k or c == choices[-1])
    own, reference = grid[k], {model: solved[model][k] for model in MODELS}

    floor = worst[k]
    # within the budget when the grid allows it; else near the floor (as the line runs' pilot)
    allowed = budget_db if floor <= budget_db else 1.05 * floor + 0.01
    if not np.isfinite(floor):   # no bounded sample in some budget band: nothing to judge a loose tol by
        candidates = candidates[-1:]
    for tol in candidates:
        estimates, job_work = {}, 0.0
        for model in MODELS:
            if tol == REFERENCE_TOL:   # the reference itself: no tolerance error left to measure
                levels, ok, w = reference[model]
            elif (model, tol, k) in kept:
                levels, ok, w = kept[(model, tol, k)]
            else:
                levels, ok, w = solve(model, tol, k)
            job_work += w
            by_tol = SPREAD_FACTOR * spread(difference(levels, reference[model][0]), ok) * scale[model]
            estimate = (by_tol + own[model]).max(axis=0)
            estimates[model] = np.where(np.isfinite(estimate), estimate, np.inf)
        if worst_in_budget(estimates, budget_mask) <= allowed or tol == candidates[-1]:
            break
    reference_work = sum(reference[m][2] for m in MODELS)
    speedup = reference_work / job_work if job_work > 0 else 1.0
    return SurfaceErrors(np.asarray(bands), budget_mask, estimates, float(speedup),
                         tuple(int(t) for t in pilot_tiles), float(tol), int(k))
