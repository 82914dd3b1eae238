"""The study's candidates (steps 3 and 4 of :mod:`roadtex.budget.study`): the settings a pilot may
choose, one study row per (setting, band) with its estimated level errors and cost, and the pilot's
table, :func:`convergence_study`.

A candidate is the data at an interval dx (the file's, or the run resampled coarser) on a model grid
k times finer at a solver tolerance; its enveloped and pressure levels on the pilot segments are
compared with the reference's (:class:`roadtex.budget.study.Pilot`), the texture levels on every
segment of the run.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import polars as pl

from roadtex._checks import positive, whole_number
from roadtex.budget.estimate import MEASURED, NOT_CONVERGING, NOT_MEASURED, PILOT_SPREAD_FACTOR, difference, run_extreme
from roadtex.budget.noise import DEFAULT_ERROR_BUDGET_DB
from roadtex.budget.sizes import five_smooth_ladder
from roadtex.budget.study import (
    COARSEST_DX,
    DEFAULT_PILOT_SEGMENTS,
    DEFAULT_TOLERANCES,
    LADDER_RATIO,
    REFERENCE_TOL,
    REFINE_LADDER,
    STUDY_SCHEMA,
    Pilot,
    band_columns,
    build_pilot,
    match,
    pilot_heights,
    pilot_segment_levels,
    segments_of,
    solve_levels,
)
from roadtex.errors import InvalidInputError
from roadtex.models.grid import DEFAULT_INTERPOLANT
from roadtex.profiles.profile import Profile
from roadtex.spectra.levels import band_levels


def texture_errors(pilot: Pilot, dx: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Texture level error per band over every segment at ``dx`` (resampling only), reported flags, points."""
    heights, starts, used = segments_of(pilot.cleaned, dx, pilot.segment_length)
    levels = band_levels(heights, used, kind=pilot.band_kind, periodic=True, method=pilot.band_method)
    columns, ok = band_columns(levels.bands, pilot.bands["band"].to_numpy())
    rows = match(starts, pilot.starts)
    error = difference(levels.levels[rows][:, columns], pilot.texture).max(axis=0)
    return np.where(ok, error, np.inf), heights[match(starts, pilot.pilot)], heights.shape[1]


def richardson_note(pilot: Pilot, band: int) -> str:
    """How the reference's own error of column ``band`` was judged (:func:`richardson`): a flag
    (one halving, not converging) of either level kind wins; "not refined" without a reference error."""
    if pilot.richardson is None:
        return "not refined"
    notes = set(pilot.richardson[:, band].tolist())
    return next((n for n in (NOT_CONVERGING, NOT_MEASURED) if n in notes), MEASURED)


def candidate_rows(pilot: Pilot, dx: float, tols: Sequence[float], refine: int = 1) -> list[dict]:
    """One study row per (tol, band) for the data at ``dx`` on a model grid ``refine`` times finer
    (the reference's own rows at the file's dx, the reference's refinement and :data:`REFERENCE_TOL`,
    when its rungs are the file's grids refined: see :attr:`Pilot.off_grid` and :func:`reference_rows`)."""
    is_file_dx = abs(dx - pilot.dx) <= 1e-9 * pilot.dx
    if is_file_dx:
        texture = np.zeros(pilot.bands.height)
        heights = None   # the pilot segments, solved by pilot_segment_levels
        used, points = pilot.dx, pilot.points
    else:
        texture, heights, points = texture_errors(pilot, dx)
        used = pilot.segment_length / points
    metres = (len(pilot.pilot) if heights is None else heights.shape[0]) * pilot.segment_length
    rows = []
    for tol in tols:
        # a rung of the reference is this candidate's solve only when it is on the file's grid refined
        is_rung = is_file_dx and tol == REFERENCE_TOL and refine in pilot.sequence and not pilot.off_grid
        if is_rung:
            solved, seconds_per_metre, work_per_metre = pilot.sequence[refine]
            ok = np.ones(pilot.bands.height, bool)
        else:
            solved, ok, seconds, work = (pilot_segment_levels(pilot, tol, refine) if is_file_dx
                                         else solve_levels(pilot, heights, used, tol, refine))
            seconds_per_metre, work_per_metre = seconds / metres, work / metres
        errors = run_extreme(solved, pilot.levels, pilot.run_rows, PILOT_SPREAD_FACTOR, pilot.sampled) + pilot.reference_error
        rows += study_rows(pilot, used, points, refine, tol, is_rung and refine == pilot.refine, texture,
                           np.where(ok, errors, np.inf), (seconds_per_metre, work_per_metre))
    return rows


def reference_rows(pilot: Pilot) -> list[dict]:
    """The study rows of the reference itself (tol :data:`REFERENCE_TOL`, refinement K, errors its
    own): :func:`candidate_rows`' where its rungs are the file's grids refined, else rows of its own
    grid (``points`` :meth:`Pilot.rung_points` (1), ``model_dx`` the rung K's interval), which no
    job solves and :func:`roadtex.budget.pilot.choose_setting` never chooses."""
    if not pilot.off_grid:
        return candidate_rows(pilot, pilot.dx, [REFERENCE_TOL], pilot.refine)
    errors = np.broadcast_to(pilot.reference_error, (2, pilot.bands.height))
    return study_rows(pilot, pilot.rung_dx(1), pilot.rung_points(1), pilot.refine, REFERENCE_TOL, True,
                      np.zeros(pilot.bands.height), errors, (pilot.seconds_per_metre, pilot.work_per_metre))


def study_rows(pilot: Pilot, dx: float, points: int, refine: int, tol: float, is_reference: bool,
               texture: np.ndarray, errors: np.ndarray, cost: tuple[float, float]) -> list[dict]:
    """One study row per band of a setting: ``dx`` (m) and ``points`` a segment, refined ``refine``
    times, at ``tol``; ``texture`` (bands,) and ``errors`` (2, bands: enveloped, pressure) in dB;
    ``cost``: (seconds, work) per metre."""
    rows = []
    for j, band in enumerate(pilot.bands.iter_rows(named=True)):
        row = {
            "dx": dx, "points": points, "refine": int(refine), "model_dx": dx / refine, "tol": float(tol),
            "reference": bool(is_reference), "band": band["band"],
            "label": band["label"], "centre_wavelength": band["centre_wavelength"],
            "in_budget": band["in_budget"], "seconds_per_metre": cost[0], "work_per_metre": cost[1],
            "texture_error_db": float(texture[j]), "enveloped_error_db": float(errors[0, j]),
            "pressure_error_db": float(errors[1, j]), "pilot_segments": len(pilot.pilot),
            "richardson": richardson_note(pilot, j),
            # a setting a job can run (not a reference on a grid of its own, Pilot.off_grid)
            "choosable": not (is_reference and pilot.off_grid),
        }
        row["level_error_db"] = max(row["texture_error_db"], row["enveloped_error_db"], row["pressure_error_db"])
        rows.append(row)
    return rows


def rung_levels(pilot: Pilot, tol: float, k: int) -> tuple[np.ndarray, np.ndarray, float, float]:
    """:func:`solve_levels` of the pilot segments on the reference's rung ``k`` at ``tol``: the
    candidate's solve (:func:`pilot_segment_levels`) where the rungs are the file's grids refined,
    else a solve of the rung's own grid (so that a tolerance's effect is measured on one grid)."""
    if not pilot.off_grid:
        return pilot_segment_levels(pilot, tol, k)
    return solve_levels(pilot, pilot_heights(pilot), pilot.dx, tol, k, points=pilot.rung_points(k))


def default_dx_ladder(pilot: Pilot) -> list[float]:
    """The file's dx, then segment_length / N for 5-smooth N, coarsening by about LADDER_RATIO down to
    COARSEST_DX (or while the shortest budget band stays reported)."""
    budget = pilot.bands.filter(pl.col("in_budget"))
    shortest = float(budget["centre_wavelength"].min()) if budget.height else pilot.dx * 2.5
    coarsest = min(COARSEST_DX, shortest / 2.5)
    lowest = max(8, int(np.ceil(pilot.segment_length / coarsest)))
    ladder = [n for n in five_smooth_ladder(pilot.points, lowest, ratio=LADDER_RATIO) if n < pilot.points]
    return [pilot.dx] + [pilot.segment_length / n for n in ladder]


def default_settings(pilot: Pilot, dxs: Sequence[float] | None = None,
                     refines: Sequence[int] | None = None) -> list[tuple[float, int]]:
    """Candidate (dx, k) settings from the coarsest model grid to the finest: the data resampled
    to each of ``dxs`` (default :func:`default_dx_ladder`) on its own grid, then the file's dx
    refined by each of ``refines`` (default :data:`REFINE_LADDER` up to the reference's K). Given
    ``refines`` apply to every dx."""
    dx_list = list(dxs) if dxs is not None else default_dx_ladder(pilot)
    if refines is not None:
        settings = [(dx, int(k)) for dx in dx_list for k in refines]
    else:
        settings = [(dx, 1) for dx in dx_list]
        settings += [(pilot.dx, k) for k in REFINE_LADDER if 1 < k <= pilot.refine
                     and any(abs(dx - pilot.dx) <= 1e-9 * pilot.dx for dx in dx_list)]
    return sorted(set(settings), key=lambda s: (-s[0] / s[1], s[1]))


def check_candidates(values: Sequence[float] | None, name: str) -> list[float] | None:
    if values is None:
        return None
    out = [positive(v, name, "m" if name == "dx_candidates" else "relative residual") for v in values]
    if not out:
        raise InvalidInputError(f"{name} must hold at least one value")
    return out


def as_frame(rows: list[dict]) -> pl.DataFrame:
    return pl.DataFrame(rows, schema=STUDY_SCHEMA).sort("dx", "refine", "tol", "band")


def convergence_study(profile: Profile | Sequence[Profile], *, youngs_modulus: float | Sequence[float],
                      mean_pressure: float, poisson: float = 0.5, segment_length: float = 0.5,
                      dx_candidates: Sequence[float] | None = None, tol_candidates: Sequence[float] | None = None,
                      n_segments: int = DEFAULT_PILOT_SEGMENTS, band_kind: str = "third_octave",
                      spike_alpha: float | None = None, max_iterations: int = 2000,
                      threads: int | None = None, include_reference_error: bool = True,
                      refine_candidates: Sequence[int] | None = None,
                      budget_db: float = DEFAULT_ERROR_BUDGET_DB, band_method: str = "dft",
                      interpolant: str = DEFAULT_INTERPOLANT) -> pl.DataFrame:
    """The pilot's table: the estimated level error and the cost of every (dx, k, tol) candidate.

    Args:
        profile: a run as read (:func:`roadtex.read_profile`), or a sequence of runs of the same
            device and pavement (one study for the group).
        youngs_modulus: rubber modulus E (Pa), or several (errors are the worst over them).
        mean_pressure: P (Pa).
        poisson: nu of the rubber.
        segment_length: length of the job's segments (m).
        dx_candidates: sampling intervals to try (m); None: the file's, then segment_length / N for
            5-smooth N (FFT-friendly), about 1.2 times coarser each, down to 0.5 mm.
        tol_candidates: solver tolerances to try; None: :data:`DEFAULT_TOLERANCES` (1e-3, 1e-4, 1e-6).
        n_segments: pilot segments, spread evenly along the run(s).
        band_kind: "third_octave" or "octave".
        spike_alpha: the job's spike criterion for conditioning (None: none).
        max_iterations, threads: passed to :func:`roadtex.contact_many`.
        include_reference_error: True (default): errors against the converged answer (the data's
            grid refined until converged, see the module docstring), the reference's own error
            included; False: errors against the data's own grid (file dx, k = 1, the reference tol),
            whose own error is then left out.
        refine_candidates: model grid refinements k to try on every dx (None: the file's dx
            refined 2, 3, 4, 6, ... times up to the reference's).
        budget_db: the budget (dB) the reference converges to a quarter of.
        band_method: "dft" (default) or "filter": how the levels are computed (the job's ``--band-method``).
        interpolant: the road between readings on the model grids (the job's ``--interpolant``,
            :data:`roadtex.models.grid.INTERPOLANTS`).

    Returns:
        A polars table, one row per (dx, k, tol, band) for the bands reported at the file's dx:
        ``dx`` (m, the data's interval), ``points`` (per segment at dx), ``refine`` (k),
        ``model_dx`` (m, dx / k), ``tol``, ``reference`` (the file's dx at the reference's k and
        tol, :data:`REFERENCE_TOL`),
        ``band``, ``label``, ``centre_wavelength`` (m), ``in_budget`` (a tyre/road noise band, see
        :mod:`roadtex.budget.noise`), ``seconds_per_metre`` (wall time of the solves, every
        modulus, per metre of road), ``texture_error_db``, ``enveloped_error_db``,
        ``pressure_error_db`` (upper estimates of each level's numerical error, dB, worst over
        segments and moduli; inf where the band is not reported at that dx), ``level_error_db``
        (the largest of the three), ``pilot_segments``, ``richardson`` and ``choosable`` (False
        only for the reference's rows where its rungs are a grid of their own, N not 5-smooth:
        no setting a job runs).

    Raises:
        InvalidInputError: bad arguments, a run too short for one segment, no reported band.
    """
    pilot = build_pilot(profile, youngs_moduli=youngs_modulus, mean_pressure=mean_pressure, poisson=poisson,
                        segment_length=segment_length, n_segments=n_segments, band_kind=band_kind,
                        spike_alpha=spike_alpha, max_iterations=max_iterations, threads=threads,
                        include_reference_error=include_reference_error, budget_db=budget_db, interpolants=False,
                        band_method=band_method, interpolant=interpolant)
    refines = None if refine_candidates is None else [whole_number(k, "refine_candidates", 1) for k in refine_candidates]
    settings = default_settings(pilot, check_candidates(dx_candidates, "dx_candidates"), refines)
    tols = check_candidates(tol_candidates, "tol_candidates") or list(DEFAULT_TOLERANCES)
    rows: list[dict] = []
    for dx, k in settings:
        rows.extend(candidate_rows(pilot, dx, tols, k))
    return as_frame(rows)
