"""How the band levels of a run converge with the model grid, the sampling interval and the solver tolerance.

The engine of the error budget (:func:`roadtex.budget.choose_setting`) and its public face,
:func:`convergence_study`. A setting is (dx, k, tol): the run conditioned at the data interval dx,
its segments joined into a continuous road (the job's interpolant, monotone cubic by default: see
:mod:`roadtex.models.grid`) and solved on a model grid k
times finer (dx / k, :mod:`roadtex.models.grid`), at solver tolerance tol. For a run (or a group
of runs of the same device and pavement):

1. **Reference**: the run conditioned at the file's own dx, cut into segments; a few *pilot*
   segments, spread evenly along the run, are solved at the reference tolerance (1e-6) on model
   grids k = 1, 2, 4, ... times finer than the data, until its own error (step 2) is within a
   quarter of the budget (:data:`REFERENCE_SHARE`) or the grid reaches
   :data:`REFERENCE_MAX_POINTS` points per segment (:data:`MAX_REFINE` at most). The finest, k =
   K, is the reference: the converged answer *for the road the samples describe*.
2. **Reference's own error** (Richardson over the k sequence, :func:`richardson`): with an error
   ~ C (dx / k)^p, per level kind and band, the reference's error is |L(K) - L(K / 2)| / (r - 1)
   for the shrink r = 2^p of the last two halvings measured in that band (capped at
   2^:data:`MAX_ORDER`; an order below 1 keeps its larger factor). A shrink below
   :data:`MIN_SHRINK` (not converging) or a single halving (order unknown) gets factor 4, is
   flagged (the study's ``richardson`` column) and makes the reference refine further while it may.
   Spread to the whole run as in 4. The reference stops refining as soon as this error is within
   :data:`REFERENCE_SHARE` of the budget: data already fine stop at K = 2 when k = 1 and 2 agree
   within a sixteenth of the budget (factor 4 on one halving).
3. **Candidates**: the data's grid refined k times (k <= K), and, where the data are finer than
   the budget needs, the run resampled to coarser intervals (k = 1); the pilot segments solved at
   each candidate tol; the difference of every level from the reference's.
4. **Estimate** per (setting, band), each an upper estimate of |level - converged level| on any
   row of the run (any segment, any modulus):

   - texture (resampling only, no solve): measured on *every* segment of the run, exactly; 0 on
     the file's own interval (texture levels are the data's whatever the model grid);
   - enveloped and pressure levels: from the pilot rows (segments x moduli), per level kind and
     band the larger of their largest difference and :data:`PILOT_SPREAD_FACTOR` (1.7) x (|mean| +
     sqrt(2 ln n) x standard deviation) of the signed differences, n the run's row count
     (:func:`run_extreme`; nothing extrapolated when the pilot's rows are the run's), plus the
     reference's own error (step 2).

5. **What the sampling cannot tell** (:func:`interpolant_spread`): the reference grid solved again
   on the other shape-preserving road through the same readings (the linear road for the default
   monotone cubic); the largest difference of its converged levels from the job's road's, spread to
   the run as in 4 (the band-limited road is left out:
   see :data:`SPREAD_INTERPOLANTS`). It is the data's
   resolution, not the solver's error, and is stated apart from it.

Time per metre is the wall time of the pilot solves (every modulus) per metre of pilot segments.
This module builds the reference (steps 1, 2 and 5); the candidates' rows (steps 3 and 4) and the
pilot's table, :func:`convergence_study`, are :mod:`roadtex.budget.candidates`'.
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import polars as pl

from roadtex._checks import poisson_ratio, positive, whole_number
from roadtex.budget.estimate import (  # noqa: F401 - re-exported: the rule's names as study's
    MAX_ORDER,
    MEASURED,
    MIN_SHRINK,
    NOT_CONVERGING,
    NOT_MEASURED,
    PILOT_SPREAD_FACTOR,
    REFERENCE_SHARE,
    SPREAD_FACTOR,
    TINY_DIFFERENCE_DB,
    difference,
    extreme,
    reference_converged,
    richardson,
    run_extreme,
    stated_errors,
)
from roadtex.budget.noise import DEFAULT_ERROR_BUDGET_DB, in_budget
from roadtex.budget.sizes import is_five_smooth, next_five_smooth
from roadtex.errors import InvalidInputError, RoadtexWarning
from roadtex.models.contact import contact_many
from roadtex.models.grid import (
    DEFAULT_INTERPOLANT,
    Interpolant,
    check_interpolant,
    prolong_pressure,
    refine_periodic,
    resample_periodic,
)
from roadtex.profiles.conditioning import clean
from roadtex.profiles.coverage import MAX_MISSING_SHARE, flat_segments, height_scale, missing_shares, too_few_readings
from roadtex.profiles.profile import Profile
from roadtex.spectra.bands import REFERENCE_PRESSURE, BandKind, check_band_kind
from roadtex.spectra.levels import Method, band_levels

#: Tolerance of the reference solves (relative residual): the pilots' ladders of model grids, lines
#: and surfaces. 1e-6 since 0.5.5 (1e-10 before): the levels are the converged ones to far below
#: the budget's resolution, for a fifth less solver work. Measured (issue 39 / 40, 2026-11-28) against
#: the same solves at 1e-10: 12 segments of the 1 km bench archive at 0.5 mm (4 moduli, k = 2 to 16)
#: levels within 1.2e-4 dB, 11 to 18 iterations against 16 to 24 (1e-8: 5e-7 dB, 13.5 to 21); the
#: demo's three 1 mm surface windows at k = 4 and 8 within 1.8e-4 dB, 28 to 38 % less solver work
#: (k = 8: 9.7 s against 12.2 s). Through the job (CAPTIF as measured, the 1 km archive, the demo's
#: surfaces) the same k and tol everywhere, the same levels, the stated errors moved by at most 6e-5 dB.
REFERENCE_TOL = 1e-6

#: Candidate solver tolerances, loosest first (lines and surfaces), down to the reference's own
#: (a candidate tighter than the reference could not be told from it). 1e-3 since 0.5.0 (issue 39):
#: on the monotone cubic road the line pilots chose it for every group of a 1 km archive at 0.5 mm
#: (k = 3 to 6), with 15 % fewer iterations than at 1e-4 and the same k; each candidate's error is
#: measured against the reference like every other, so a tol that moves the levels is not chosen.
#: Nothing looser: with 3e-3, rows erred more than stated (a tail 12 pilot segments miss; issue 39,
#: ``benches/model_grid.py --line-tolerances``, benches/HISTORY-0.5.8.md).
DEFAULT_TOLERANCES = (1e-3, 1e-4, REFERENCE_TOL)

#: Pilot segments per run (or per group of runs), spread evenly along it: 12, measured (see
#: :data:`PILOT_SPREAD_FACTOR`): with 3, 6 and 8 segments the same rule fell short of the actual
#: error by up to 0.56, 0.25 and 0.22 dB (cement concrete, porous asphalt), with 12 by 0.09 dB at most.
DEFAULT_PILOT_SEGMENTS = 12

#: Coarsest candidate sampling interval (m): the ISO 13473-1 MPD sampling.
COARSEST_DX = 0.5e-3

#: Largest reference grid, in points per segment (beyond it the reference stops refining, its own
#: error stated as it stands); one refinement (k = 2) is always made, whatever the size.
REFERENCE_MAX_POINTS = 2 ** 16

#: Largest refinement of the reference grid.
MAX_REFINE = 32

#: Candidate refinements of the data's grid, cheapest first (5-smooth: FFT-friendly when N is). The
#: surface pilot has its own, shorter one (roadtex.budget.areal.REFINE_LADDER: a surface costs k^2).
#: 5, 10 and 20 since 0.5.9 (2026-12-02, 1 km archives): cement concrete at 0.5 mm and porous asphalt
#: and surface dressing at 1 mm took k = 5 instead of 6 (5,000-point segments 8 % cheaper than 6,000:
#: 5^4 costs 11 % more per point), both jobs about 7 % faster (medians of 4 alternated pairs), no row
#: of either erring more than stated against k = 32; 7 was no cheaper than 8.
REFINE_LADDER = (1, 2, 3, 4, 5, 6, 8, 10, 12, 16, 20, 24, 32)

#: Ratio between neighbouring candidate point counts.
LADDER_RATIO = 1.2

KINDS = ("texture", "enveloped", "pressure")

STUDY_SCHEMA = {
    "dx": pl.Float64, "points": pl.Int64, "refine": pl.Int64, "model_dx": pl.Float64, "tol": pl.Float64,
    "reference": pl.Boolean, "band": pl.Int64,
    "label": pl.String, "centre_wavelength": pl.Float64, "in_budget": pl.Boolean,
    "seconds_per_metre": pl.Float64, "work_per_metre": pl.Float64, "texture_error_db": pl.Float64, "enveloped_error_db": pl.Float64,
    "pressure_error_db": pl.Float64, "level_error_db": pl.Float64, "pilot_segments": pl.Int64,
    "richardson": pl.String, "choosable": pl.Boolean,
}


@dataclass
class Pilot:
    """The reference side of a study: pilot segments, reference levels, the reference's own error."""

    cleaned: list[Profile]           # the runs, cleaned once (:func:`cleaned_profiles`)
    moduli: np.ndarray
    mean_pressure: float
    poisson: float
    segment_length: float
    band_kind: BandKind
    max_iterations: int
    threads: int | None
    dx: float
    points: int
    bands: pl.DataFrame              # reported bands of the reference, with in_budget
    pilot: list[tuple[int, float]]   # (profile index, segment start m) of each pilot segment
    run_rows: int                    # rows (segments x moduli) of the whole run
    texture: np.ndarray              # (all segments, bands) reference texture levels
    starts: list[tuple[int, float]]  # (profile index, start) of every segment, rows of ``texture``
    levels: np.ndarray               # (2, pilot rows, bands) enveloped, pressure at the reference
    reference_error: np.ndarray      # (2, bands) reference's own error estimate
    seconds_per_metre: float
    work_per_metre: float
    refine: int = 1                  # K: the reference's model grid is dx / K
    richardson: np.ndarray | None = None   # (2, bands) how each reference error was judged (richardson())
    # k -> (levels, seconds per metre, work per metre) of the pilot segments at REFERENCE_TOL on each grid solved
    sequence: dict[int, tuple[np.ndarray, float, float]] = dataclasses.field(default_factory=dict)
    interpolant_spread: np.ndarray | None = None   # (bands,) what the sampling cannot tell (dB)
    band_method: Method = "dft"      # how the job computes band levels: the pilot's levels the same way
    interpolant: Interpolant = DEFAULT_INTERPOLANT   # the job's road between readings: the pilot solves the same
    # (k, tol) -> solve_levels' result for the pilot segments at the file's dx (not the reference's
    # rungs): a candidate and the tolerance effect that ask for the same solve share it
    solved: dict[tuple[int, float], tuple[np.ndarray, np.ndarray, float, float]] = dataclasses.field(
        default_factory=dict)
    # points a segment of the reference's k = 1 rung (:func:`ladder_points`; rung k has k times as
    # many): ``points`` where that is FFT-friendly, else the next 5-smooth count (0: ``points``)
    ladder: int = 0
    # the pilot's runs are a sample of a larger group (the job's): its rows never stand for all rows
    # (:func:`roadtex.budget.estimate.run_extreme`)
    sampled: bool = False

    def rung_points(self, k: int) -> int:
        """Points a segment of the reference's rung k."""
        return (self.ladder or self.points) * int(k)

    def rung_dx(self, k: int) -> float:
        """The model interval (m) of the reference's rung k: the file's dx / k on its own grid."""
        return self.dx / k if not self.off_grid else self.dx * self.points / self.rung_points(k)

    @property
    def off_grid(self) -> bool:
        """Whether the reference's rungs are grids other than the file's refined k times (then no
        rung is a candidate's solve)."""
        return self.rung_points(1) != self.points


def ladder_points(points: int) -> int:
    """Points a segment of the reference's k = 1 rung for data of ``points`` a segment: the data's
    own count when it is 5-smooth, else the next 5-smooth count (the same road on a slightly finer
    grid, 1.2 % for CAPTIF's, :func:`roadtex.models.grid.resample_periodic`). The rungs are k times
    that: on CAPTIF's 13,337-point segments (a prime: every FFT of N k points takes the slow
    algorithm) 13,500 k, solved 1.6, 1.4 and 1.8 times faster at k = 1, 2 and 4 (issue 39, 2026-12-04).
    Only with a reference error (:func:`build_pilot`'s ``include_reference_error``): else the
    reference is the data's own grid."""
    return points if is_five_smooth(points) else next_five_smooth(points)


def as_profiles(profile: Profile | Sequence[Profile]) -> list[Profile]:
    profiles = [profile] if isinstance(profile, Profile) else list(profile)
    if not profiles or not all(isinstance(p, Profile) for p in profiles):
        raise InvalidInputError("profile must be a roadtex Profile or a non-empty sequence of Profiles "
                                "(runs of the same device and pavement)")
    dxs = {round(p.dx, 15) for p in profiles}
    if len(dxs) != 1 and max(dxs) > 1.01 * min(dxs):
        raise InvalidInputError("the profiles of a group must share their sampling interval (dx, m)")
    return profiles


def cleaned_profiles(profiles: list[Profile], spike_alpha: float | None) -> list[Profile]:
    """Each run cleaned once (plates trimmed, spikes and outliers flagged, as the job does), so that
    every candidate interval only repeats the cheap rest of the chain (:meth:`Profile.finished`):
    the same profiles as :meth:`Profile.conditioned` gives, bit for bit."""
    with warnings.catch_warnings():  # the job reports the run's cleaning itself
        warnings.simplefilter("ignore", RoadtexWarning)
        return [clean(profile, spike_alpha=spike_alpha)[0] for profile in profiles]


def segments_of(cleaned: list[Profile], dx: float | None,
                segment_length: float) -> tuple[np.ndarray, list[tuple[int, float]], float]:
    """Every segment with a level of every cleaned profile, finished at ``dx`` (None: the file's):
    heights, (profile, start), dx. A segment mostly filled (drop-outs: more than
    :data:`~roadtex.profiles.coverage.MAX_MISSING_SHARE` of its samples without a reading) or flat
    (no texture: :func:`~roadtex.profiles.coverage.flat_segments`) has no level in the job, so the
    pilot never measures its errors on one.

    Raises:
        InvalidInputError: no segment of any profile has a level.
    """
    heights, starts, used = [], [], 0.0
    for index, profile in enumerate(cleaned):
        # Profile.finished's steps, keeping apart the samples that had no reading
        resampled = profile.resample(profile.dx if dx is None else dx)
        segments = resampled.fill_dropouts().detrend("linear").segments(segment_length)
        shares = missing_shares(np.isnan(resampled.heights), segments.start_indices, segments.heights.shape[1])
        keep = ~too_few_readings(shares) & ~flat_segments(segments.heights, height_scale(resampled.heights))
        heights.append(segments.heights[keep])
        starts.extend((index, float(s)) for s in segments.starts[keep])
        used = segments.dx
    lengths = {h.shape[1] for h in heights}
    if len(lengths) != 1:
        raise InvalidInputError("the profiles of a group give segments of different point counts")
    if not starts:
        raise InvalidInputError(f"no segment of {segment_length:g} m of the pilot's runs has a level: each has more "
                                f"than {MAX_MISSING_SHARE:.0%} of its samples missing (drop-outs) or its readings "
                                "on a straight line (no texture)")
    return np.vstack(heights), starts, used


def match(starts: list[tuple[int, float]], wanted: list[tuple[int, float]]) -> np.ndarray:
    """Row of ``starts`` nearest each of ``wanted`` (same profile)."""
    rows = []
    for profile, start in wanted:
        same = [(abs(s - start), i) for i, (p, s) in enumerate(starts) if p == profile]
        rows.append(min(same)[1])
    return np.asarray(rows, dtype=np.int64)


def band_columns(levels_bands: pl.DataFrame, bands: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns of ``bands`` in a level table, and whether each is reported there."""
    numbers = levels_bands["band"].to_numpy()
    reported = levels_bands["reported"].to_numpy()
    columns = np.array([int(np.flatnonzero(numbers == b)[0]) if b in numbers else 0 for b in bands])
    ok = np.array([b in numbers and bool(reported[numbers == b][0]) for b in bands])
    return columns, ok


def contact_levels(envelope: np.ndarray, pressure: np.ndarray, dx: float, bands: np.ndarray, kind: BandKind,
                   method: Method = "dft") -> tuple[np.ndarray, np.ndarray]:
    """Enveloped and pressure levels (2, rows, bands) of solved signals (..., x; m and Pa) sampled
    every ``dx`` m, in the columns of the band numbers ``bands``, and whether each is reported at ``dx``."""
    n = envelope.shape[-1]
    env = band_levels(envelope.reshape(-1, n), dx, kind=kind, periodic=True, method=method)
    pres = band_levels(pressure.reshape(-1, n), dx, kind=kind, periodic=True, method=method,
                       reference=REFERENCE_PRESSURE)
    columns, ok = band_columns(env.bands, bands)
    return np.stack([env.levels[:, columns], pres.levels[:, columns]]), ok


def solver_work(iterations: np.ndarray, points: int) -> float:
    """Iterations x N log2 N summed over solves of ``points`` points: a cost measure that, unlike the
    seconds, does not depend on the machine's load, so that the same inputs choose the same setting."""
    return float(np.sum(iterations)) * points * np.log2(points)


def solve_levels(pilot: Pilot, heights: np.ndarray, dx: float, tol: float, refine: int = 1,
                 interpolant: Interpolant | None = None, initial_pressure: np.ndarray | None = None,
                 keep: dict[int, np.ndarray] | None = None,
                 points: int | None = None) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Enveloped and pressure levels (2, rows, bands) of ``heights`` (sampled every ``dx``) solved on
    a model grid ``refine`` times finer at ``tol`` (the readings joined by ``interpolant``, by default
    the job's, ``pilot.interpolant``), reported flags, seconds, and the work (:func:`solver_work`).
    ``initial_pressure`` (rows, moduli, points; Pa): each problem's start (else the moduli chained,
    as the job solves); ``keep``: receives the pressures solved, as ``keep[refine]``; ``points``: a
    model grid of that many points a segment instead (a reference rung, :meth:`Pilot.rung_points`)."""
    start = time.perf_counter()
    road = pilot.interpolant if interpolant is None else interpolant
    n = heights.shape[-1]
    if points is None or points == n * refine:
        model, model_dx = refine_periodic(heights, refine, road), dx / refine
    else:
        model, model_dx = resample_periodic(heights, points, road), dx * n / points
    batch = contact_many(model, model_dx, pilot.moduli, pilot.mean_pressure, poisson=pilot.poisson, tol=tol,
                         max_iterations=pilot.max_iterations, threads=pilot.threads,
                         warm_start=initial_pressure is None, initial_pressure=initial_pressure,
                         raise_on_nonconvergence=False)
    seconds = time.perf_counter() - start
    levels, ok = contact_levels(batch.envelope, batch.pressure, model_dx, pilot.bands["band"].to_numpy(),
                                pilot.band_kind, pilot.band_method)
    if keep is not None:
        keep[refine] = batch.pressure
    return levels, ok, seconds, solver_work(batch.iterations, model.shape[1])


def pilot_segment_levels(pilot: Pilot, tol: float, refine: int) -> tuple[np.ndarray, np.ndarray, float, float]:
    """:func:`solve_levels` of the pilot segments at the file's dx, ``refine`` and ``tol``, solved
    once per pilot (a candidate setting and the tolerance effect on the same rung are one solve)."""
    key = (int(refine), float(tol))
    if key not in pilot.solved:
        pilot.solved[key] = solve_levels(pilot, pilot_heights(pilot), pilot.dx, tol, refine)
    return pilot.solved[key]


def pilot_heights(pilot: Pilot) -> np.ndarray:
    """The pilot segments' heights at the file's dx (pilot rows, points)."""
    heights, _, _ = segments_of(pilot.cleaned, None, pilot.segment_length)
    return heights[match(pilot.starts, pilot.pilot)]


def build_pilot(profile: Profile | Sequence[Profile], *, youngs_moduli: float | Sequence[float],
                mean_pressure: float, poisson: float, segment_length: float, n_segments: int,
                band_kind: str, spike_alpha: float | None, max_iterations: int,
                threads: int | None, include_reference_error: bool = True,
                budget_db: float = DEFAULT_ERROR_BUDGET_DB, max_refine: int = MAX_REFINE,
                interpolants: bool = True, band_method: str = "dft", group_scale: float = 1.0,
                interpolant: str = DEFAULT_INTERPOLANT, sampled: bool = False) -> Pilot:
    """The reference side of a study (module docstring, steps 1, 2 and 5): ``max_refine`` caps K;
    ``interpolant``: the job's road between readings (every pilot solve joins the readings so);
    ``group_scale``: how many times the pilot's runs' rows the group it speaks for holds (its
    errors are extrapolated to the largest of that many rows); ``sampled``: the runs are a sample
    of a group of more runs (:func:`~roadtex.budget.estimate.run_extreme`);
    ``interpolants`` False skips step 5; ``include_reference_error`` False solves the data's own
    grid only (K = 1) and states no reference error; ``band_method`` ("dft" or "filter") is how
    the job computes its band levels, and so every level of the pilot."""
    profiles = as_profiles(profile)
    moduli = np.atleast_1d(np.asarray(youngs_moduli, dtype=np.float64))
    if moduli.size == 0 or not np.all(np.isfinite(moduli) & (moduli > 0)):
        raise InvalidInputError(f"youngs_modulus must be positive moduli (Pa), got {youngs_moduli!r}")
    count = whole_number(n_segments, "n_segments", 1)
    kind = check_band_kind(band_kind)
    length = positive(segment_length, "segment_length", "m")
    budget = positive(budget_db, "budget_db", "dB")
    largest_refine = whole_number(max_refine, "max_refine", 1)
    if band_method not in ("dft", "filter"):
        raise InvalidInputError(f"band_method must be 'dft' or 'filter', got {band_method!r}")
    method: Method = "filter" if band_method == "filter" else "dft"
    road = check_interpolant(interpolant)
    cleaned = cleaned_profiles(profiles, spike_alpha)
    heights, starts, dx = segments_of(cleaned, None, length)
    texture = band_levels(heights, dx, kind=kind, periodic=True, method=method)
    bands = texture.bands.filter(pl.col("reported"))
    if bands.is_empty():
        raise InvalidInputError(f"no band is reported for segments of {length:g} m sampled every {dx:.3g} m")
    bands = bands.with_columns(pl.Series("in_budget", in_budget(bands["band"].to_numpy(), dx, length, kind)))
    columns, _ = band_columns(texture.bands, bands["band"].to_numpy())
    chosen = np.unique(np.round(np.linspace(0, len(starts) - 1, min(count, len(starts)))).astype(np.int64))
    pilot = Pilot(cleaned, moduli, positive(mean_pressure, "mean_pressure", "Pa"), poisson_ratio(poisson),
                  length, kind, whole_number(max_iterations, "max_iterations", 1), threads, dx,
                  heights.shape[1], bands, [starts[i] for i in chosen],
                  int(np.ceil(heights.shape[0] * moduli.size * max(float(group_scale), 1.0))),
                  texture.levels[:, columns], starts, np.empty(0), np.empty(0), 0.0, 0.0, band_method=method,
                  interpolant=road, sampled=bool(sampled),
                  # without a reference error the reference is the data's own grid (k = 1), whatever N
                  ladder=ladder_points(heights.shape[1]) if include_reference_error else heights.shape[1])
    pilot_heights = heights[chosen]
    metres = chosen.size * length
    # Each rung starts from the last one's pressures prolonged (the same readings, half the
    # interval: 15 to 30 % less time than the moduli chained at k = 4 to 16, issue 39); the
    # pressures of the finest rung the interpolants' spread can be solved on start its other roads.
    last: dict[int, np.ndarray] = {}
    spread_start: dict[int, np.ndarray] = {}

    def solve(k: int) -> np.ndarray:
        below = next(iter(last.items()), None)
        start = prolong_pressure(below[1], k // below[0]) if below is not None and k % below[0] == 0 else None
        kept: dict[int, np.ndarray] = {}
        levels, _, seconds, work = solve_levels(pilot, pilot_heights, dx, REFERENCE_TOL, k, initial_pressure=start,
                                                keep=kept, points=pilot.rung_points(k))
        last.clear()
        last.update(kept)
        if interpolants and pilot.rung_points(k) <= SPREAD_MAX_POINTS:   # the spread's grid: the finest that fits
            spread_start.clear()
            spread_start.update(kept)
        pilot.sequence[k] = (levels, seconds / metres, work / metres)
        return levels

    budget_rows = bands["in_budget"].to_numpy()
    differences: list[np.ndarray] = []   # extreme |L(k) - L(k / 2)| per halving, (2, bands)
    finest = solve(1)
    k = 1
    while include_reference_error and 2 * k <= largest_refine:
        if k > 1 and pilot.rung_points(2 * k) > REFERENCE_MAX_POINTS:
            break
        finer = solve(2 * k)
        differences.append(run_extreme(finer, finest, pilot.run_rows, sampled=pilot.sampled))
        finest, k = finer, 2 * k
        if reference_converged(differences, budget_rows, budget):
            break
    pilot.refine = k
    pilot.levels = finest
    pilot.seconds_per_metre, pilot.work_per_metre = pilot.sequence[k][1], pilot.sequence[k][2]
    if not differences:
        pilot.reference_error = np.zeros(pilot.levels[:, 0].shape)
        return pilot
    pilot.reference_error, pilot.richardson = richardson(differences)
    if interpolants:
        pilot.interpolant_spread = interpolant_spread(pilot, pilot_heights, spread_start)
    return pilot


#: The roads through the readings whose converged levels the spread compares (each with the job's
#: own, :func:`spread_interpolants`): the shape-preserving ones. The band-limited road is measured
#: (benches/model_grid.py) but left out: it rings at sharp stone tops, adding up to 10 dB at 0.5 mm
#: in the short bands, while real fine data averaged to 0.5 mm differ from their own fine solve by
#: about 1 dB per segment (the sampling calibration on CAPTIF, :mod:`roadtex.budget.sampling`): not a
#: road the samples allow.
SPREAD_INTERPOLANTS: tuple[str, ...] = ("pchip", "linear")


def spread_interpolants(interpolant: str) -> tuple[str, ...]:
    """The roads a job joining its readings by ``interpolant`` is compared with for the spread: the
    shape-preserving ones (:data:`SPREAD_INTERPOLANTS`) other than its own."""
    return tuple(other for other in SPREAD_INTERPOLANTS if other != interpolant)


#: Largest model grid (points a segment) the interpolants' spread is solved on (issue 39): below
#: the reference's where the data are fine. The spread is the difference of two roads on one grid
#: (0.1 to 3 dB), whose grid errors largely cancel: on CAPTIF at 0.0375 mm (13,337 points a segment)
#: it is taken at k = 2 instead of the reference's k = 4 (the pchip solve was 15 of the pilot's 59 s).
#: A rung of at most two points a reading on the readings' grid is not taken (:func:`interpolant_spread`):
#: data of more than half this many points a segment get a grid of their own, about 2 N points.
SPREAD_MAX_POINTS = 2 ** 15

#: Tolerance of the other roads' solves of the interpolants' spread: the spread is 0.1 to 4 dB, and
#: at 1e-6 the levels move by under 1e-5 dB from their 1e-10 solves for a quarter less solver work
#: (the 1 km bench archive's cement concrete at k = 16 and dense asphalt at k = 8, issue 39). Since
#: 0.5.5 the reference is solved at that tolerance too: the spread's roads are solved as the reference is.
SPREAD_TOL = REFERENCE_TOL


def interpolant_spread(pilot: Pilot, heights: np.ndarray,
                       start: dict[int, np.ndarray] | None = None) -> np.ndarray:
    """The largest difference (dB, per band) between the converged enveloped and pressure levels of
    the job's road (``pilot.interpolant``) and those of the other shape-preserving roads through the
    same readings (:func:`spread_interpolants`: the linear road for the default monotone cubic), on
    the finest grid of the reference's sequence within :data:`SPREAD_MAX_POINTS` (the reference's own
    where it fits), spread to the run's rows as the errors are: what the data's sampling cannot tell
    about the road between its readings. Where that grid is the readings' own or holds every other
    one (k = 1, or k = 2 on the file's grid refined), both roads are solved on the next 5-smooth
    count above two points a reading instead, off the readings (there the roads agree).

    ``start``: the job's road's pressures on grids of the sequence (k -> (rows, moduli, points), Pa),
    from which the other roads' solves start where given (issue 39: on the 1 km bench archive's
    segments at k = 8 and 16, 27 % less time than the moduli chained, the levels within SPREAD_TOL)."""
    fitting = [k for k in pilot.sequence if pilot.rung_points(k) <= SPREAD_MAX_POINTS]
    k = pilot.refine if pilot.refine in fitting or not fitting else max(fitting)
    points = pilot.rung_points(k)
    if k == 1 or (k == 2 and not pilot.off_grid):
        # Every point (k = 1) or every other point (k = 2) of that grid a reading, where the roads
        # agree: their difference under-sampled, nil at k = 1 (fine data, N > SPREAD_MAX_POINTS / 2).
        # Both roads on about two points a reading off the readings instead (CAPTIF at 0.0375 mm,
        # the 2.5 mm band: 0.027 dB at k = 2 on the readings' grid, 0.069 off them, 0.056 to 0.065
        # converged; issue 39, benches/HISTORY-0.5.8.md 0.5.14).
        points = next_five_smooth(2 * heights.shape[1] + 1)
        own, _, _, _ = solve_levels(pilot, heights, pilot.dx, SPREAD_TOL, k, points=points)
        initial = None
    else:
        own = pilot.sequence[k][0]
        initial = (start or {}).get(k)
    spread = np.zeros(pilot.bands.height)
    for interpolant in spread_interpolants(pilot.interpolant):
        levels, _, _, _ = solve_levels(pilot, heights, pilot.dx, SPREAD_TOL, k, interpolant,  # type: ignore[arg-type]
                                       initial_pressure=initial, points=points)
        spread = np.fmax(spread, extreme(np.moveaxis(difference(levels, own), 1, 0), pilot.run_rows).max(axis=0))
    return spread
