"""One surface run of the bulk job (3D texture): read, condition, solve with the areal model on
tiles and with the line model on lines of the same surface; its tables, nothing written.

How a surface run is cut and solved (documented choices):

- Tiles are ``segment_length`` along the road (overlapping by ``segment_overlap``) by the whole
  width of the surface across it (surfaces are measured as strips a few decimetres wide; a tile
  is one footprint-sized periodic cell). Each tile's least-squares plane is removed.
- :data:`SURFACE_LINES` rows evenly spread across the surface are the lines. The line model
  solves, for each line, the same stretches as the tiles (the line's samples under the tile,
  its least-squares line removed), so the line and areal rows of one (segment, line) compare the
  same road.
- Areal band levels are taken along those rows of each tile's enveloped surface (and of its
  pressure map): ``bands.parquet`` holds one row per (model, segment, line, modulus, band).
- The surface is solved on a *model grid* ``k`` times finer than its own spacings ``dx``, ``dy``
  each way (the readings joined by ``options.interpolant``, monotone cubics each way by default:
  :func:`roadtex.models.grid.refine_periodic_surface`; the line model's rows ``k`` times finer
  along). With an error budget, an areal pilot on a few of its tiles (:mod:`roadtex.budget.areal`;
  the job's pilot is of line runs) chooses ``k`` (unless ``options.refine`` forces it) and its
  tolerance (unless the job's was given) and estimates its levels' errors: ``level_errors`` per
  (model, band), which the job joins into bands.parquet ``level_error_db`` and runs.parquet.
  Without one, ``options.refine`` (1 when None: the data's grid) and the job's tolerance.
- Texture levels are the data's (its own grid). Enveloped and pressure levels come from the model
  grid, in the data's bands (the fine grid's shorter bands are not reported); an analysed row's
  pressure is the mean over the row's width ``dy`` (:func:`roadtex.budget.areal.row_strips`).
  runs.parquet states the grid: ``refine``, ``refine_across``, ``model_dx``, ``model_dy``.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from roadtex.archive.areal_outputs import areal_table
from roadtex.archive.compute import ALLOW_IMPLAUSIBLE, plausibility_notes, run_stage, segment_mpd
from roadtex.archive.options import DEFAULT_TOL, ProcessingOptions
from roadtex.archive.plan import JobPlan, RunPlan
from roadtex.archive.reading import surface_reader_options
from roadtex.archive.schemas import (
    RUN_RUN_SCHEMA,
    SURFACE_ERROR_SCHEMA,
    SURFACE_EXAMPLE_SCHEMA,
)
from roadtex.archive.tables import band_frame, defined_levels, model_levels, segment_frame
from roadtex.budget.areal import (
    AREAL_PILOT_POINTS,
    MAX_MODEL_POINTS,
    WINDOW_FACTOR,
    SurfaceErrors,
    pilot_tile_indices,
    pilot_window,
    refine_ladder,
    row_strips,
    surface_level_errors,
)
from roadtex.budget.noise import in_budget
from roadtex.budget.study import DEFAULT_TOLERANCES
from roadtex.errors import ErrorBudgetWarning, InvalidInputError, RunFailure
from roadtex.models.contact import contact_many
from roadtex.models.grid import coarse_points, reading_means, refine_periodic, refine_periodic_surface
from roadtex.models.results import contact_measures
from roadtex.models.surface import contact_surface_many
from roadtex.profiles.conditioning import CleaningSummary, outlier_mask
from roadtex.profiles.coverage import flat_segments, height_scale
from roadtex.profiles.mpd import mpd as mean_profile_depth
from roadtex.profiles.plausibility import implausible_across, judged_once
from roadtex.profiles.trend import remove_lines
from roadtex.spectra.analysis import time_frequency
from roadtex.spectra.bands import REFERENCE_PRESSURE
from roadtex.spectra.levels import band_levels
from roadtex.surfaces.conditioning import clean as clean_surface
from roadtex.surfaces.readers import read_surface
from roadtex.surfaces.surface import Surface
from roadtex.surfaces.tiles import plane_fits

#: Lines (rows evenly spread across the surface) solved with the line model and analysed.
SURFACE_LINES = 5
#: Fewest rows across the road the areal model takes (its solver's least, 4 points each way).
MIN_SURFACE_ROWS = 4
#: Surface points per solver call: the tiles of a run are solved a chunk of this many points at a
#: time, so memory does not grow with the run's length (as CHUNK_SEGMENTS does for line runs).
CHUNK_POINTS = 4_000_000

def condition_surface(raw: Surface, spike_alpha: float | None) -> tuple[Surface, CleaningSummary, np.ndarray]:
    """Gross outliers (drop-out codes) and spikes flagged as the line runs flag them
    (:func:`roadtex.surfaces.conditioning.clean`), drop-outs filled, the least-squares plane
    removed; returns the surface, what cleaning removed (with its notes beyond the line runs'
    WARN_* thresholds) and where it had no reading (True: filled; roadtex.profiles.coverage)."""
    cleaned, summary = clean_surface(raw, spike_alpha)
    return cleaned.fill_dropouts().remove_plane(), summary, np.isnan(cleaned.heights)


def tile_coverage(missing: np.ndarray, tiles: Any, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The share of samples without a reading (``missing``, the surface's mask) of each tile
    (tiles,) and of each analysed row ``rows`` within each tile (tiles, rows)."""
    _, n_y, n_x = tiles.heights.shape
    whole = np.array([missing[r:r + n_y, c:c + n_x].mean() for r, c in zip(tiles.row_starts, tiles.column_starts)])
    lines = np.array([[missing[row, c:c + n_x].mean() for row in rows] for c in tiles.column_starts])
    return whole, lines.reshape(len(whole), len(rows))


def line_rows(rows: int) -> np.ndarray:
    """Indices of the :data:`SURFACE_LINES` rows evenly spread across a surface of ``rows`` rows."""
    return np.unique(np.linspace(0, rows - 1, min(SURFACE_LINES, rows)).round().astype(int))


def compute_surface_run(run: dict[str, Any], plan: JobPlan | ProcessingOptions, *,
                        threads: int | None = None) -> dict[str, Any]:
    """Reads, conditions, tiles and solves one surface run with the areal and the line model.

    The surface is solved at its own spacings, on the model grid and at the tolerance its plan
    entry gives (:meth:`~roadtex.archive.plan.JobPlan.surface_entry`), or those its own areal pilot
    chooses where the entry leaves them to it. ``plan`` may be bare :class:`ProcessingOptions`.

    Returns:
        The run's tables (``segments``, ``bands``, ``run``; ``example`` is None), as line runs
        give them, with ``model`` "line" or "areal" and ``line`` the row index of the surface;
        ``surface_example``: the middle tile solved at the middle modulus (for the report); and
        ``level_errors`` (SURFACE_ERROR_SCHEMA; None without an error budget, or when the areal
        pilot could not run): the error estimate of each model's levels per band;
        ``areal``: ISO 25178-2 parameters of the surface and of each tile (AREAL_SCHEMA);
        ``pilot_note`` (a string, not a table): why the pilot could not run, else None; and the
        notes on plausibility, ``implausible_note`` and ``sampling_note``
        (:func:`~roadtex.archive.compute.plausibility_notes`); ``plan_entry``: its plan entry.

    Raises:
        RunFailure: with the stage that failed (read, condition, mpd, segment, spectra, solve).
    """
    plan = plan if isinstance(plan, JobPlan) else JobPlan.given(plan)
    options, entry = plan.options, plan.surface_entry()
    name = Path(run["path"]).name
    reader = surface_reader_options(run, options)
    # judged here, and refused or noted: no warning from the reader that it computes as given
    with judged_once():
        raw = run_stage("read", lambda: read_surface(run["path"], **reader))
    # judged without the gross outliers (drop-out codes), which conditioning removes
    outliers = run_stage("condition", lambda: outlier_mask(raw))
    finite = raw.heights[np.isfinite(raw.heights) & ~outliers]
    if not finite.size:
        raise RunFailure("read", InvalidInputError(f"{name}: no valid reading"))
    notes = plausibility_notes(finite[None, :], raw.dx, name, raw.metadata, options, given_dx=reader.get("dx"),
                               given_unit=reader.get("distance_unit"), row="surface")
    across = implausible_across(raw.dy, raw.shape[0], name, tile_length=options.segment_length)
    if across is not None and not options.allow_implausible:   # rows 1 m apart ran past 100 s (issue 38)
        raise RunFailure("read", InvalidInputError(f"{across} If the file is right as read, {ALLOW_IMPLAUSIBLE}."))
    surface, cleaning, missing = run_stage("condition", lambda: condition_surface(raw, options.spike_alpha))
    if surface.shape[0] < MIN_SURFACE_ROWS:  # refused before any solve, naming the file
        raise RunFailure("read", InvalidInputError(
            f"{name}: {surface.shape[0]} row(s) across the road ({surface.width * 1e3:.3g} mm wide): the areal "
            f"model needs at least {MIN_SURFACE_ROWS}; a single line is a profile (format omitted)"))
    tiles = run_stage("segment", lambda: surface.tiles(options.segment_length, surface.width,
                                                       (options.segment_overlap, 0.0)))
    tile_points = tiles.heights.shape[1] * tiles.heights.shape[2]
    if entry.refine is not None and tile_points * entry.refine ** 2 > MAX_MODEL_POINTS:
        # a forced k costs k^2 points a tile: refused before any solve (the pilot never chooses such a k)
        raise RunFailure("segment", InvalidInputError(
            f"{name}: a model grid {entry.refine} times finer each way would give tiles of "
            f"{tile_points * entry.refine ** 2:,} points, above {MAX_MODEL_POINTS:,}: use a smaller --refine "
            "(or none: the error budget's pilot chooses) or shorter segments"))
    rows = line_rows(surface.shape[0])
    lines = run_stage("segment", lambda: surface.lines(rows=rows.tolist()))
    coverage = tile_coverage(missing, tiles, rows)
    depths = [run_stage("mpd", lambda p=p: mean_profile_depth(p, spike_alpha=options.mpd_spike_alpha)) for p in lines]
    moduli = np.asarray(options.youngs_moduli, dtype=np.float64)
    n_tiles, n_y, n_x = tiles.heights.shape
    dx = surface.dx
    speed = run.get("speed_kmh")
    speed = options.speed_kmh if speed is None or not np.isfinite(speed) else speed
    starts = tiles.x0 + dx * tiles.column_starts

    method, kind = options.band_method, options.band_kind
    # every band is judged on the tile length alone: refuse before any solve when none is reported
    bands = run_stage("spectra", lambda: band_levels(surface.heights[:1, :tiles.heights.shape[2]], dx, kind=kind,
                                                     periodic=True, method=method).bands)
    if not bands["reported"].any():
        raise RunFailure("spectra", InvalidInputError(
            f"no {kind.replace('_', '-')} band is allowed by the sampling ({dx:.3g} m) and the tile "
            f"length ({tiles.length:.3g} m); use longer segments"))
    frequency = (run_stage("spectra", lambda: time_frequency(bands["centre_wavelength"].to_numpy(), speed))
                 if speed is not None else np.full(bands.height, np.nan))
    line_mpd = np.stack([segment_mpd(d.segments, starts, tiles.length, max(dx, 5e-4)) for d in depths], axis=1)
    errors, pilot_note = None, None
    if options.error_budget_db is not None:
        try:
            errors = run_stage("pilot", lambda: pilot_errors(tiles, lines, rows, moduli, bands, options, entry, threads))
        except RunFailure as failure:  # as a line group's pilot: recorded and warned, the run goes on
            pilot_note = f"the areal pilot failed: {type(failure.cause).__name__}: {failure.cause}"
        if errors is None and pilot_note is None:
            n_y, n_x = tiles.heights.shape[1:]
            pilot_note = (f"tiles of {n_y} x {n_x} points: even one window of the areal pilot exceeds its "
                          f"{AREAL_PILOT_POINTS} points on its finest model grid")
        if pilot_note is not None:
            warnings.warn(f"{name} (run {run['run_id']!r}): {pilot_note}; its levels have no error estimate "
                          "(level_error_db null; parameters.json surface_pilot_notes)", ErrorBudgetWarning, stacklevel=2)
    # the pilot's choices (the given ones when forced), else the entry's
    tol = (entry.tol or DEFAULT_TOL) if errors is None else errors.tol
    refine = (entry.refine or 1) if errors is None else errors.refine   # the model grid's k, each way
    # Memory stays bounded as for line runs: the tiles are solved a chunk at a time (the solver's
    # envelopes and pressures, for every modulus, are what grows with the run's length).
    chunk = max(1, CHUNK_POINTS // (n_y * n_x * refine ** 2))
    # rows by model, then tile: the same order whatever the chunking
    by_model: dict[str, dict[str, list[pl.DataFrame]]] = {"bands": {}, "segments": {}}
    example = None
    for first in range(0, n_tiles, chunk):
        part = np.arange(first, min(first + chunk, n_tiles))
        frames = solve_chunk(run, options, tol, tiles, part, lines, rows, moduli, bands, frequency, line_mpd,
                             starts, threads, refine, coverage, height_scale(surface.heights))
        for table in ("bands", "segments"):
            for frame in frames[table]:
                by_model[table].setdefault(frame["model"][0], []).append(frame)
        if frames["example"] is not None:
            example = frames["example"]
    band_frames = [f for frames_ in by_model["bands"].values() for f in frames_]
    segment_frames = [f for frames_ in by_model["segments"].values() for f in frames_]
    return {
        "plan_entry": entry,
        "example": None,
        "surface_example": example,
        "level_errors": None if errors is None else error_table(run["run_id"], errors),
        "pilot_note": pilot_note,
        "segments": pl.concat(segment_frames),
        "bands": defined_levels(pl.concat(band_frames)),
        "run": surface_run_table(run, raw, surface, cleaning, depths, n_tiles, tol, refine),
        "areal": run_stage("segment", lambda: areal_table(run["run_id"], surface, tiles)),
        **notes,
    }


def solve_chunk(run: dict[str, Any], options: ProcessingOptions, tol: float, tiles: Any, part: np.ndarray,
                lines: list[Any],
                rows: np.ndarray, moduli: np.ndarray, bands: pl.DataFrame, frequency: np.ndarray,
                line_mpd: np.ndarray, starts: np.ndarray, threads: int | None, refine: int,
                coverage: tuple[np.ndarray, np.ndarray], scale: float) -> dict[str, Any]:
    """The tiles ``part`` of a surface run solved with both models at ``tol`` on the model grid
    ``refine`` times finer each way: their band and segment rows (tile numbers as in the whole
    run; ``coverage``: :func:`tile_coverage`; a row whose analysed line is flat to within rounding
    of ``scale``, m, has no level: :func:`roadtex.profiles.coverage.flat_segments`), and the
    report's example when the middle tile is among them."""
    dx, dy = tiles.dx, tiles.dy
    n_x = tiles.heights.shape[2]
    band_frames: list[pl.DataFrame] = []
    segment_frames: list[pl.DataFrame] = []
    heights, line_heights, frame_shift = tile_lines(tiles, part, lines, rows)
    n_tiles = part.size
    # (tiles, lines): an analysed line on a straight line (a plate, a held reading) has no texture
    flat_rows = flat_segments(line_heights, scale)
    # the model grid (k = 1: the data's own arrays, unchanged)
    fine_heights = refine_periodic_surface(heights, refine, refine, options.interpolant)  # type: ignore[arg-type]
    fine_lines = refine_periodic(line_heights, refine, options.interpolant)  # type: ignore[arg-type]
    fine_x = n_x * refine
    areal = run_stage("solve", lambda: contact_surface_many(
        fine_heights, dx / refine, dy / refine, youngs_modulus=moduli, mean_pressure=options.mean_pressure,
        poisson=options.poisson, tol=tol, max_iterations=options.max_iterations, threads=threads, warm_start=True,
        raise_on_nonconvergence=False))
    flat = line_heights.reshape(-1, n_x)
    line_batch = run_stage("solve", lambda: contact_many(
        fine_lines.reshape(-1, fine_x), dx / refine, moduli, options.mean_pressure, poisson=options.poisson, tol=tol,
        max_iterations=options.max_iterations, threads=threads, warm_start=True, raise_on_nonconvergence=False))

    method, kind = options.band_method, options.band_kind
    texture = run_stage("spectra", lambda: band_levels(flat, dx, kind=kind, periodic=True, method=method))
    # [tile, modulus, line, x]: the analysed data rows on the model grid (see roadtex.budget.areal)
    # the move into the line model's frame refined as the road is (the difference of the two roads)
    shift = refine_periodic(frame_shift, refine, options.interpolant)  # type: ignore[arg-type]
    areal_env = areal.envelope[:, :, rows * refine, :] - shift[:, None]
    areal_p = row_strips(areal.pressure, rows, refine)
    line_env = line_batch.envelope.reshape(n_tiles, len(rows), moduli.size, fine_x)
    line_p = line_batch.pressure.reshape(n_tiles, len(rows), moduli.size, fine_x)

    def levels(values: np.ndarray, reference: float | None = None) -> np.ndarray:
        return run_stage("spectra", lambda: model_levels(values.reshape(-1, fine_x), dx / refine, bands, kind=kind,
                                                         method=method, reference=reference))

    texture_levels = texture.levels.reshape(n_tiles, len(rows), 1, -1)
    tile_missing, line_missing = coverage[0][part], coverage[1][part]
    n_bands = bands.height
    band_frames = []
    for model, env, pres in (("line", line_env, line_p),
                             ("areal", np.moveaxis(areal_env, 1, 2), np.moveaxis(areal_p, 1, 2))):
        # env, pres: [tile, line, modulus, x]
        env_levels = levels(env).reshape(n_tiles, len(rows), moduli.size, n_bands)
        p_levels = levels(pres, REFERENCE_PRESSURE).reshape(n_tiles, len(rows), moduli.size, n_bands)
        tile_i, line_k, mod_i = (a.ravel() for a in np.meshgrid(np.arange(n_tiles), np.arange(len(rows)),
                                                                np.arange(moduli.size), indexing="ij"))
        # a line model's row has a level where its own stretch was measured, an areal row where its tile was
        missing = line_missing[tile_i, line_k] if model == "line" else tile_missing[tile_i]
        # the sampling calibration is of line runs' levels (roadtex.budget.sampling): none stated here
        band_frames.append(band_frame(run["run_id"], model, part[tile_i], rows[line_k], moduli[mod_i], bands, frequency,
                                      np.broadcast_to(texture_levels, env_levels.shape), env_levels, p_levels, missing,
                                      flat_rows[tile_i, line_k]))

    line_mpd = line_mpd[part]
    segment_frames = []
    line_measures = contact_measures(fine_lines[:, :, None, :], line_p, line_env)
    # the mean of the tile's lines' MPD; NaN (null) for a tile without any valid baseline (counted
    # by hand: numpy's nanmean warns, and a warnings filter would be process-wide)
    valid = np.isfinite(line_mpd)
    with np.errstate(invalid="ignore", divide="ignore"):
        areal_mpd = np.where(valid, line_mpd, 0.0).sum(axis=1) / valid.sum(axis=1)
    areal_measures = contact_measures(fine_heights.reshape(n_tiles, 1, -1),
                                      areal.pressure.reshape(n_tiles, moduli.size, -1),
                                      areal.envelope.reshape(n_tiles, moduli.size, -1))
    line_iter = line_batch.iterations.reshape(n_tiles, len(rows), moduli.size)
    line_res = line_batch.residual.reshape(n_tiles, len(rows), moduli.size)
    line_conv = line_batch.converged.reshape(n_tiles, len(rows), moduli.size)
    tile_i, line_i, mod_i = (a.ravel() for a in np.meshgrid(np.arange(n_tiles), np.arange(len(rows)),
                                                            np.arange(moduli.size), indexing="ij"))
    segment_frames.append(segment_frame(run, "line", part[tile_i], rows[line_i], moduli[mod_i], starts[part[tile_i]],
                                        tiles.length, line_mpd[tile_i, line_i],
                                        line_heights.std(axis=-1)[tile_i, line_i],
                                        {k: v[tile_i, line_i, mod_i] for k, v in line_measures.items()},
                                        line_res[tile_i, line_i, mod_i], line_iter[tile_i, line_i, mod_i],
                                        line_conv[tile_i, line_i, mod_i], line_missing[tile_i, line_i],
                                        flat_rows[tile_i, line_i]))
    tile_i, mod_i = (a.ravel() for a in np.meshgrid(np.arange(n_tiles), np.arange(moduli.size), indexing="ij"))
    segment_frames.append(segment_frame(run, "areal", part[tile_i], None, moduli[mod_i], starts[part[tile_i]], tiles.length,
                                        areal_mpd[tile_i], heights.reshape(n_tiles, -1).std(axis=1)[tile_i],
                                        {k: v[tile_i, mod_i] for k, v in areal_measures.items()},
                                        areal.residual[tile_i, mod_i], areal.iterations[tile_i, mod_i],
                                        areal.converged[tile_i, mod_i], tile_missing[tile_i],
                                        flat_rows[tile_i].all(axis=-1)))
    middle = len(tiles) // 2
    example = (surface_example(run["run_id"], tiles, middle, areal, int(np.flatnonzero(part == middle)[0]), moduli,
                               refine)
               if middle in part else None)
    return {"bands": band_frames, "segments": segment_frames, "example": example}


def tile_lines(tiles: Any, part: np.ndarray, lines: list[Any],
               rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tiles ``part`` as solved (tiles, ny, nx; plane removed), the line model's stretches of them
    (tiles, lines, nx; each its own line removed), and the move of the areal rows into the line
    model's frame (tiles, lines, nx)."""
    n_x = tiles.heights.shape[2]
    heights = tiles.heights[part]
    take = tiles.column_starts[part][:, None] + np.arange(n_x)[None, :]
    line_heights = remove_lines(np.stack([p.heights[take] for p in lines], axis=1))[0]
    # tiles are detrended with their plane, the line model's stretches with their own line: the
    # areal envelope's lines are moved into the line model's frame (the linear difference of the
    # two detrendings subtracted) so that both models' spectra see the same road
    return heights, line_heights, heights[:, rows, :] - line_heights


def pilot_errors(tiles: Any, lines: list[Any], rows: np.ndarray, moduli: np.ndarray, bands: pl.DataFrame,
                 options: ProcessingOptions, entry: RunPlan, threads: int | None) -> SurfaceErrors | None:
    """The areal pilot's choice of tolerance and error estimates of the run's levels
    (:mod:`roadtex.budget.areal`), or None when one window is too large for it."""
    n_tiles, n_y, n_x = tiles.heights.shape
    top = refine_ladder(entry.refine)[-1]
    window, _ = pilot_window(n_y, n_x, rows, top)
    chosen = pilot_tile_indices(n_tiles, window.size * n_x, top)
    if chosen.size == 0:
        return None
    # the line model on every analysed row (cheap); the areal model on the window, its levels taken
    # along every row of it (each moved by its own line, as the job moves the analysed rows): more
    # samples of how a row's levels err than the one or two analysed rows a strip holds
    heights, line_heights, _ = tile_lines(tiles, chosen, lines, rows)
    heights = heights[:, window, :]
    if window.size < n_y:  # a strip of each tile, its own plane removed as tiles' are
        heights = heights - plane_fits(heights, tiles.dx, tiles.dy)
    every_row = np.arange(heights.shape[1])
    reported = bands.filter(pl.col("reported"))["band"].to_numpy()
    return surface_level_errors(
        heights, line_heights, heights - remove_lines(heights)[0], every_row, tiles.dx, tiles.dy, bands=reported,
        in_budget=in_budget(reported, tiles.dx, tiles.length, options.band_kind),
        run_rows=n_tiles * rows.size * moduli.size, youngs_moduli=moduli, mean_pressure=options.mean_pressure,
        poisson=options.poisson, budget_db=float(options.error_budget_db or 0.0),
        tols=DEFAULT_TOLERANCES if entry.tol is None else (float(entry.tol),),
        band_kind=options.band_kind,
        band_method=options.band_method, max_iterations=options.max_iterations, threads=threads,
        pilot_tiles=tuple(int(t) for t in chosen),
        window_factor=WINDOW_FACTOR if window.size < n_y else 1.0,
        refine=entry.refine, interpolant=entry.interpolant, tile_points=n_y * n_x)  # type: ignore[arg-type]


def error_table(run_id: str, errors: SurfaceErrors) -> pl.DataFrame:
    """The run's ``level_errors`` table (SURFACE_ERROR_SCHEMA): one row per (model, band)."""
    models = list(errors.level_error_db)
    count = errors.bands.size
    return pl.DataFrame({
        "run_id": [run_id] * (count * len(models)), "model": np.repeat(models, count),
        "band": np.tile(errors.bands, len(models)), "in_budget": np.tile(errors.in_budget, len(models)),
        "level_error_db": np.concatenate([errors.level_error_db[m] for m in models]),
        "speedup": np.full(count * len(models), errors.work_speedup),
        "pilot_tiles": [len(errors.pilot_tiles)] * (count * len(models)),
        "refine_along": [errors.refine] * (count * len(models)),
        "refine_across": [errors.refine] * (count * len(models)),
    }, schema=SURFACE_ERROR_SCHEMA)


def surface_run_table(run: dict[str, Any], raw: Surface, surface: Surface, cleaning: CleaningSummary, depths: list[Any],
                      n_tiles: int, tol: float, refine: int = 1) -> pl.DataFrame:
    """The run's row of runs.parquet; MPD is the mean over the analysed lines (valid when all are);
    the model grid ``refine`` times finer than the data's each way."""
    values = [d.mpd for d in depths if np.isfinite(d.mpd)]
    return pl.DataFrame({
        "run_id": [run["run_id"]], "path": [run["path"]], "format": [run.get("format")],
        "file_dx": [raw.dx], "dx_used": [surface.dx], "tol_used": [tol],
        "points": [surface.heights.size],
        "raw_length": [raw.length], "trimmed_length": [0.0], "length": [surface.length], "plates": ["none"],
        "dropout_fraction": [cleaning.dropout_fraction], "spike_fraction": [cleaning.spike_fraction],
        "outlier_fraction": [cleaning.outlier_fraction],
        "conditioning_warnings": ["; ".join(cleaning.warnings) or None], "segments": [n_tiles],
        "sampling_dx": [None], "contact_resolved_to": [None],
        "mpd": [float(np.mean(values)) if values else None],
        "mpd_valid": [bool(all(d.is_valid for d in depths))],
        "mpd_valid_baselines": [int(sum(int(d.valid_segments) for d in depths))],
        "mpd_baselines": [int(sum(int(d.segments.height) for d in depths))],
        "refine": [refine], "refine_across": [refine], "model_dx": [surface.dx / refine],
        "model_dy": [surface.dy / refine],
        "mpd_spike_rejected": [sum(d.rejected["spikes"] for d in depths)],
        "mpd_dropout_rejected": [sum(d.rejected["dropouts"] for d in depths)],
        "mpd_rejections": ["; ".join(f"line {i}: {note}" for i, d in enumerate(depths)
                                     for note in [d.rejection_note()] if note) or None],
    }, schema=RUN_RUN_SCHEMA)


def surface_example(run_id: str, tiles: Any, tile: int, areal: Any, row: int, moduli: np.ndarray,
                    refine: int = 1) -> pl.DataFrame:
    """Tile ``tile``'s heights, enveloped surface and pressure map (row ``row`` of ``areal``) at
    the middle modulus (sorted), in long form (SURFACE_EXAMPLE_SCHEMA): what the report draws
    without re-solving. On a model grid ``refine`` times finer, the envelope at the data's readings
    and the pressure over each reading's cell (its mean there: the load kept)."""
    k = int(np.argsort(moduli)[moduli.size // 2])
    _, n_y, n_x = tiles.heights.shape
    x = tiles.x0 + tiles.dx * (tiles.column_starts[tile] + np.arange(n_x))
    y = tiles.y0 + tiles.dy * (tiles.row_starts[tile] + np.arange(n_y))
    count = n_x * n_y
    return pl.DataFrame({
        "run_id": [run_id] * count, "segment": np.full(count, tile), "youngs_modulus": np.full(count, moduli[k]),
        "dx": np.full(count, tiles.dx), "dy": np.full(count, tiles.dy),
        "x": np.tile(x, n_y), "y": np.repeat(y, n_x), "height": tiles.heights[tile].ravel(),
        "envelope": coarse_points(coarse_points(areal.envelope[row, k], refine).T, refine).T.ravel(),
        "pressure": reading_means(reading_means(areal.pressure[row, k], refine).T, refine).T.ravel(),
    }, schema=SURFACE_EXAMPLE_SCHEMA)
