"""The numerical error of a surface run's levels: an areal pilot on a few of its tiles.

A surface run (3D texture) is solved at its own spacings, with the areal model on tiles and with
the line model on rows of the same tiles (see :mod:`roadtex.archive.surface_run`). Its levels get
error estimates the way a line run's do (:mod:`roadtex.budget.study`), and its solver tolerance
is chosen as loose as the budget allows, from a few *pilot* tiles spread evenly along the run:

1. **Reference**: each pilot tile (and its analysed rows, for the line model) solved at the
   reference tolerance (1e-10) at the file's spacings.
2. **Reference's own error** (Richardson): the same tiles solved at half the spacing
   each way, every height repeated over a 2 x 2 block (a row's samples repeated twice for the
   line model): the same surface as the file gives, on a grid twice as fine. The areal levels
   are taken along the mean of the two fine rows of each analysed row. The reference's own error
   is :data:`RICHARDSON_FACTOR` (3) |L(h / 2) - L(h)|: surface levels converge more slowly than
   first order (2, the line runs' factor).
3. **Tolerance**: the tiles solved at each candidate tolerance, loosest first (1e-4, 1e-6, 1e-8,
   1e-10; only the given one when the job's tol was given); the difference from the reference.
   The first candidate within the budget is the run's (:func:`surface_level_errors`).
4. **Estimate** per (model, band): as for line runs, the differences of the pilot rows extended
   to every row of the run (:func:`roadtex.budget.study.extreme`), the tolerance's times
   ``SPREAD_FACTOR``, plus the reference's own error; the larger of the enveloped and pressure
   estimates. Texture levels are the file's own (no resampling): no numerical error.

A row of a tile in contact with the rubber at one setting and not at the other (it barely touches:
its pressure level is -inf at one) differs without bound; such rows are left out of the samples,
and no estimate covers them (their pressure levels mean little at any setting).

The pilot is bounded. On a wide tile it solves a *window*: a strip of the tile along its whole
length (the same bands) and as many rows as make :data:`AREAL_WINDOW_POINTS` points, centred on the analysed row
nearest the middle, its own plane removed, solved as a periodic cell as tiles are; the areal
estimate comes from every row of it (the line model's, cheap, from every analysed row). The
discretisation error of a row's levels depends on how finely the grid resolves the contact spots
along it, which the strip's rows show as the tile's do, up to :data:`WINDOW_FACTOR` (tested
against the whole tile).
At most :data:`AREAL_PILOT_POINTS` points at half spacing over all pilot tiles (fewer tiles when
windows are large); a run whose window is too large for even one is not estimated (None).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from roadtex.budget.study import REFERENCE_TOL, SPREAD_FACTOR, contact_levels, difference, extreme, solver_work
from roadtex.models.contact import contact_many
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
#: with room (``benches/areal_budget.py``).
WINDOW_FACTOR = 1.5

#: Largest number of points at half spacing over all pilot windows (4 per point of a window): the
#: pilot's cost, about that many points solved per modulus at tol 1e-10. 2^19: four windows of
#: 2^15 points would fit, of which :data:`AREAL_PILOT_TILES` are used.
AREAL_PILOT_POINTS = 2 ** 19

MODELS = ("line", "areal")

#: Richardson factor of the reference's own error: error(h) ~ factor x |L(h / 2) - L(h)| (2 would
#: be first order, as for line runs). An empirical choice: the levels of surface runs converge more
#: slowly (rows of an areal pressure map cross contact spots that every halving resolves better).
#: On 48 cases (3 synthetic pavements x 8 seeds x 2 widths, 1 mm, 0.128 m tiles, E = 2 and 10 MPa,
#: tol 1e-6) the areal pressure levels of some bands fell only 1.3 times per halving (order 0.4,
#: whose own factor would be 4.1); against solves 8 (areal) and 16 (line) times finer, factor 2 fell
#: short by up to 0.2 dB (areal) and 0.06 dB (line), factor 3 covered every band of both models by
#: at least 1.3 times (median 3 times): pooling over neighbouring bands and the larger of the
#: enveloped and pressure estimates add the rest (``benches/areal_budget.py`` reruns the check).
#: One factor for both models: on a surface that is a profile extruded across the road, where both
#: models give the same levels, they get the same estimate.
RICHARDSON_FACTOR = 3.0


@dataclass(frozen=True)
class SurfaceErrors:
    """Error estimates of a surface run's levels at its spacings and the chosen tol.

    Attributes:
        bands: band numbers, those reported at the run's tile length and dx.
        in_budget: which of ``bands`` the budget applies to (:mod:`roadtex.budget.noise`).
        level_error_db: model ("line", "areal") -> upper estimate (dB) per band of the numerical
            error of that model's enveloped and pressure levels (the larger of the two), any row.
        work_speedup: the solver work (iterations x N log2 N, both models) at the reference
            tolerance over that at ``tol``, on the pilot tiles.
        pilot_tiles: the tiles (indices along the run) the estimate comes from.
        tol: the solver tolerance the estimates are for (the chosen one).
    """

    bands: np.ndarray
    in_budget: np.ndarray
    level_error_db: dict[str, np.ndarray]
    work_speedup: float
    pilot_tiles: tuple[int, ...]
    tol: float

    def worst_db(self) -> float:
        """The largest estimate over both models in the budget bands (dB; 0 without budget bands)."""
        return worst_in_budget(self.level_error_db, self.in_budget)


def worst_in_budget(estimates: dict[str, np.ndarray], in_budget: np.ndarray) -> float:
    """The largest of per-band ``estimates`` (model -> dB per band) in the budget bands; a
    non-finite value (no bounded sample) counts as infinite; 0 without budget bands."""
    values = [np.where(np.isfinite(e), e, np.inf)[in_budget] for e in estimates.values()]
    return float(max((v.max() for v in values if v.size), default=0.0))


def pilot_window(n_y: int, n_x: int, rows: np.ndarray) -> tuple[slice, np.ndarray]:
    """The rows of a tile (``n_y`` x ``n_x`` points, analysed ``rows``) the pilot solves: all of
    them when they fit in :data:`AREAL_WINDOW_POINTS`, else a strip of that many points (at least
    :data:`MIN_WINDOW_ROWS` rows) centred on the analysed row nearest the middle. Returns the
    strip's rows and the positions in ``rows`` of the analysed rows inside it."""
    count = min(n_y, max(MIN_WINDOW_ROWS, AREAL_WINDOW_POINTS // max(n_x, 1)))
    rows = np.asarray(rows, dtype=np.int64)
    if count >= n_y:
        return slice(0, n_y), np.arange(rows.size)
    centre = int(rows[np.argmin(np.abs(rows - 0.5 * (n_y - 1)))])
    start = int(np.clip(centre - count // 2, 0, n_y - count))
    return slice(start, start + count), np.flatnonzero((rows >= start) & (rows < start + count))


def pilot_tile_indices(n_tiles: int, points_per_window: int) -> np.ndarray:
    """Up to :data:`AREAL_PILOT_TILES` tiles spread evenly over ``n_tiles``, as many as fit in
    :data:`AREAL_PILOT_POINTS` at half spacing (empty: one window does not fit)."""
    fits = AREAL_PILOT_POINTS // (4 * max(points_per_window, 1))
    count = min(AREAL_PILOT_TILES, n_tiles, fits)
    if count <= 0:
        return np.empty(0, dtype=np.int64)
    return np.unique(np.round(np.linspace(0, n_tiles - 1, count)).astype(np.int64))


@dataclass(frozen=True)
class _Setup:
    moduli: np.ndarray
    mean_pressure: float
    poisson: float
    kind: BandKind
    method: Method
    max_iterations: int
    threads: int | None


def _line_levels(setup: _Setup, lines: np.ndarray, dx: float, tol: float,
                 bands: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The line model on rows ``lines`` (rows, x): levels (2, rows x moduli, bands), reported, work."""
    batch = contact_many(lines, dx, setup.moduli, setup.mean_pressure, poisson=setup.poisson, tol=tol,
                         max_iterations=setup.max_iterations, threads=setup.threads, warm_start=True,
                         raise_on_nonconvergence=False)
    levels, ok = contact_levels(batch.envelope, batch.pressure, dx, bands, setup.kind, setup.method)
    return levels, ok, solver_work(batch.iterations, lines.shape[-1])


def _areal_levels(setup: _Setup, heights: np.ndarray, dx: float, dy: float, tol: float, rows: np.ndarray,
                  factor: int, shift: np.ndarray, bands: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The areal model on tiles ``heights`` (tiles, ny, nx) refined ``factor`` times each way; levels
    (2, tiles x lines x moduli, bands) along the analysed ``rows`` (the mean of the ``factor`` fine
    rows of each), moved by ``shift`` (tiles, lines, nx at the file's dx) as the job moves them."""
    fine = np.repeat(np.repeat(heights, factor, axis=1), factor, axis=2)
    solved = contact_surface_many(fine, dx / factor, dy / factor, youngs_modulus=setup.moduli,
                                  mean_pressure=setup.mean_pressure, poisson=setup.poisson, tol=tol,
                                  max_iterations=setup.max_iterations, threads=setup.threads, warm_start=True,
                                  raise_on_nonconvergence=False)
    n_tiles, n_moduli = solved.envelope.shape[:2]
    nx = fine.shape[2]

    def along_rows(field: np.ndarray) -> np.ndarray:   # (tiles, moduli, fine ny, nx) -> (tiles, lines, moduli, nx)
        blocks = field.reshape(n_tiles, n_moduli, -1, factor, nx)[:, :, rows].mean(axis=3)
        return np.moveaxis(blocks, 1, 2)

    envelope = along_rows(solved.envelope) - np.repeat(shift, factor, axis=-1)[:, :, None, :]
    levels, ok = contact_levels(envelope, along_rows(solved.pressure), dx / factor, bands, setup.kind, setup.method)
    return levels, ok, solver_work(solved.iterations, fine.shape[1] * nx)


def surface_level_errors(heights: np.ndarray, lines: np.ndarray, shift: np.ndarray, rows: np.ndarray, dx: float,
                         dy: float, *, bands: np.ndarray, in_budget: np.ndarray, run_rows: int,
                         youngs_moduli: np.ndarray, mean_pressure: float, poisson: float,
                         tols: Sequence[float], budget_db: float, band_kind: BandKind, band_method: Method,
                         max_iterations: int, threads: int | None,
                         pilot_tiles: tuple[int, ...] = (), window_factor: float = 1.0) -> SurfaceErrors:
    """Error estimates of a surface run's levels from its pilot tiles, at the loosest tolerance
    that needs no more (see the module).

    The candidate tolerances ``tols`` are tried loosest first; the first whose worst estimate in
    the budget bands is within ``budget_db`` is chosen, or, when the spacing alone already errs
    more (the floor: the estimate as tol goes to 0), within 5 % (and 0.01 dB) of that floor, as the
    line runs' pilot does; the tightest otherwise. One candidate: it is estimated (a forced tol).

    Args:
        heights: the pilot tiles (or their windows, :func:`pilot_window`) as solved (tiles, ny,
            nx; m, plane removed).
        lines: the line model's stretches of every analysed row of the pilot tiles (tiles, lines,
            nx; m, each its line removed).
        shift: the move of those rows of the areal envelope into the line model's frame (tiles,
            rows, nx; m): each row's least-squares line.
        rows: the rows of ``heights`` whose areal levels are compared (indices in it, across the
            road; the job uses every row of the window).
        dx, dy: the run's spacings along and across the road (m).
        bands: band numbers to estimate (those the job reports); in_budget: which are budget bands.
        run_rows: rows (tiles x lines x moduli) of each model in the whole run.
        tols: candidate solver tolerances (relative residual).
        budget_db: the error budget (dB).
        youngs_moduli, mean_pressure, poisson, band_kind, band_method, max_iterations, threads: as
            the job solves and analyses the run (Pa, Pa, 1).
        pilot_tiles: the tiles' indices along the run (their count goes to the run's table).
        window_factor: multiplies the areal estimate: :data:`WINDOW_FACTOR` when ``heights`` are
            windows of the run's tiles, 1 for whole tiles.

    Returns:
        A :class:`SurfaceErrors` at the chosen tolerance.
    """
    setup = _Setup(np.asarray(youngs_moduli, dtype=np.float64), mean_pressure, poisson, band_kind, band_method,
                   max_iterations, threads)
    flat = lines.reshape(-1, lines.shape[-1])
    budget_mask = np.asarray(in_budget, dtype=bool)

    def solve(model: str, tol: float, factor: int = 1) -> tuple[np.ndarray, np.ndarray, float]:
        if model == "line":
            return _line_levels(setup, np.repeat(flat, factor, axis=-1), dx / factor, tol, bands)
        return _areal_levels(setup, heights, dx, dy, tol, rows, factor, shift, bands)

    def spread(measured: np.ndarray, ok: np.ndarray) -> np.ndarray:
        """(2, bands): the differences (2, pilot rows, bands) extended to every row of the run. A
        row in contact at one setting and not at the other (its pressure level -inf at one: an
        unbounded difference) is left out of the sample (see the module)."""
        sample = np.where(ok & np.isfinite(measured), measured, np.nan)
        return extreme(np.moveaxis(sample, 1, 0), run_rows)

    reference = {model: solve(model, REFERENCE_TOL) for model in MODELS}
    # Richardson: L(h) - L(0) ~ factor (L(h) - L(h / 2)); the spacing's part of every estimate
    own = {}
    scale = {"line": 1.0, "areal": window_factor}   # a window's areal estimate, scaled up as a whole
    for model in MODELS:
        halved, ok_half, _ = solve(model, REFERENCE_TOL, factor=2)
        own[model] = RICHARDSON_FACTOR * spread(difference(halved, reference[model][0]), ok_half) * scale[model]

    floor = worst_in_budget({m: own[m].max(axis=0) for m in MODELS}, budget_mask)
    # within the budget when the spacing allows it; else near the floor (as the line runs' pilot)
    allowed = budget_db if floor <= budget_db else 1.05 * floor + 0.01
    candidates = sorted(tols, reverse=True)
    if not np.isfinite(floor):   # no bounded sample in some budget band: nothing to judge a loose tol by
        candidates = candidates[-1:]
    for tol in candidates:
        estimates, job_work = {}, 0.0
        for model in MODELS:
            if tol == REFERENCE_TOL:   # the reference itself: no tolerance error left to measure
                levels, ok, w = reference[model]
            else:
                levels, ok, w = solve(model, tol)
            job_work += w
            by_tol = SPREAD_FACTOR * spread(difference(levels, reference[model][0]), ok) * scale[model]
            estimate = (by_tol + own[model]).max(axis=0)
            estimates[model] = np.where(np.isfinite(estimate), estimate, np.inf)
        if worst_in_budget(estimates, budget_mask) <= allowed or tol == candidates[-1]:
            break
    reference_work = sum(reference[m][2] for m in MODELS)
    speedup = reference_work / job_work if job_work > 0 else 1.0
    return SurfaceErrors(np.asarray(bands), budget_mask, estimates, float(speedup),
                         tuple(int(t) for t in pilot_tiles), float(tol))
