"""The line pilot's error rule (issue 39): the Richardson factor of the reference's own error and the
extrapolation from the pilot's rows to the whole run. The rule is written out in
docs/guide/error-budget.md ("The Richardson rule"); :mod:`roadtex.budget.study` applies it.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import polars as pl

from roadtex.budget.noise import DEFAULT_ERROR_BUDGET_DB

#: The reference grid stops refining once its own estimated error is at most this share of the budget.
REFERENCE_SHARE = 0.25

#: Largest convergence order Richardson assumes from the k sequence (the safe side of the measured
#: orders: 1.3 to 2.5 between successive halvings on CAPTIF averaged to 1 mm): factor >= 0.55.
MAX_ORDER = 1.5

#: Least shrink per halving (r = 2^p, p >= 0.32) the Richardson rule (:func:`richardson`) trusts;
#: below it the sequence is flagged as not converging and the reference refines further.
MIN_SHRINK = 1.25

#: A halving's difference (dB) at or below this is the solver's noise, not a trend (at the reference
#: tol, 1e-6, the levels lie within 2e-4 dB of their 1e-10 solves: roadtex.budget.study.REFERENCE_TOL).
TINY_DIFFERENCE_DB = 1e-3

#: How the Richardson factor of a band was judged (the study's ``richardson`` column).
MEASURED, NOT_MEASURED, NOT_CONVERGING = "order measured", "one halving: factor 4", "not converging: factor 4"

#: Safety factor on the line pilot's extrapolation from its segments to the whole run
#: (:func:`run_extreme`), with DEFAULT_PILOT_SEGMENTS (12) pilot segments: replayed on every segment
#: of 4 synthetic pavements and CAPTIF averaged to 1 mm (40 and 10 segments, 4 moduli, k = 1 to 16
#: against k = 32, benches/pilot_calibration.py), 1.7 states a median 1.7 to 1.9 times the actual
#: error per group (1.1 on CAPTIF, whose 10 segments were all in the pilot); 6 of 585 (k, band)
#: cases fell below it, 2 by more than 0.01 dB (0.09 dB at k = 1, over the budget anyway; 0.015 dB
#: at k = 8 in the 40 mm band); 2 gave medians 2.0 to 2.2. The old rule (magnitudes, factor 2,
#: 3 segments): median 2.5, 19 of 520 below, up to 0.29 dB. SPREAD_FACTOR stays the areal pilot's.
PILOT_SPREAD_FACTOR = 1.7

#: Safety factor on the extrapolation of the Gaussian extreme of magnitudes (:func:`extreme`): the
#: areal pilot's (:mod:`roadtex.budget.areal`). Level errors between segments are heavy-tailed (one
#: segment may err 5 times more than the pilot's rms): on 8 synthetic pavements x 10 settings x 6
#: bands (10 segments, 3 in the pilot) the pooled Gaussian extrapolation was exceeded by the true
#: largest error in 29 % of the cases, by 1.5 times it in 11 %, by 2 times it in 4.6 % (95th
#: percentile of the ratio 0.96, largest 2.5); see docs/guide/error-budget.md.
SPREAD_FACTOR = 2.0


#: How a level's stated error grows where its band holds less power than is typical of its group:
#: as the power's square root, the band's amplitude (a level L dB below the group's median level of
#: that band and modulus states 10^(L / 20) times the group's error; at or above the median, the
#: group's). A grid's error adds a field e to the band's signal s, and the level moves by about
#: 8.7 |e| / |s| cos(angle) dB: for an error field of a given size the dB error grows as the
#: amplitude falls (exponent 1/2 on power); an error proportional to the signal moves every level
#: alike (exponent 0). Measured on every row of a 1 km archive at 0.5 mm against k = 32 (issue 39,
#: benches/model_grid.py --check-runs 0): the 25 of 324,480 (row, kind) levels beyond their group's
#: statement lay 2.8 to 15 dB below the median and needed exponents up to 0.32 (porous asphalt,
#: 20 mm band); the group rule alone stated 0.68 times the actual at worst (dense asphalt, 31.5 mm).
BELOW_TYPICAL_EXPONENT = 0.5


def below_typical_factor(level_db: pl.Expr, typical_db: pl.Expr) -> pl.Expr:
    """The factor (>= 1) on a group's stated error for a level ``level_db`` whose group's typical
    (median) level of its band and modulus is ``typical_db`` (dB; polars expressions): 10^(0.5
    (typical - level) / 10) below the median (:data:`BELOW_TYPICAL_EXPONENT`), 1 at or above it and
    where either is not finite (a band without power: its level is not a number to scale by)."""
    below = typical_db - level_db
    return (pl.when(below.is_finite() & (below > 0.0)).then(10.0 ** (BELOW_TYPICAL_EXPONENT * below / 10.0))
            .otherwise(1.0))


def difference(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a - b| in dB, 0 where both are -inf (bands without power), inf where only one is."""
    with np.errstate(invalid="ignore"):
        d = np.abs(a - b)
    return np.where(np.isneginf(a) & np.isneginf(b), 0.0, np.where(np.isnan(d), np.inf, d))


def run_extreme(levels: np.ndarray, reference: np.ndarray, run_rows: int, factor: float = 1.0,
                sampled: bool = False) -> np.ndarray:
    """Estimate (2, bands) of the largest |levels - reference| among ``run_rows`` rows from the pilot's
    rows (levels and reference: (2, pilot rows, bands), dB): per level kind and band, the larger of
    the pilot's largest difference and ``factor`` x (|mean| + sqrt(2 ln run_rows) x standard
    deviation) of the signed differences. A grid's level errors are mostly a bias shared by the
    segments (a coarse grid flattens every contact spot alike) plus a scatter: the Gaussian
    extreme of the scatter added to the bias, not of the magnitudes (which counted the bias
    sqrt(2 ln n) = 3 to 4.5 times). When the pilot's rows are the run's (a run of at most
    :data:`DEFAULT_PILOT_SEGMENTS` segments) nothing is extrapolated: the largest difference is the
    run's, unless ``sampled``: the rows are a sample of runs the pilot did not solve (a job's group
    of more runs than the pilot read), whose own extremes the sample's largest does not bound. Inf
    where only one of the two is -inf (a band without power at one setting), 0 where both are.
    """
    with np.errstate(invalid="ignore"):
        signed = np.where(np.isneginf(levels) & np.isneginf(reference), 0.0, levels - reference)
    signed = np.where(np.isnan(signed), np.inf, signed)
    largest = np.abs(signed).max(axis=1)
    if signed.shape[1] >= run_rows and not sampled:
        return largest
    with np.errstate(invalid="ignore"):
        gaussian = np.abs(signed.mean(axis=1)) + np.sqrt(2.0 * np.log(max(run_rows, 2))) * signed.std(axis=1)
    return np.fmax(largest, factor * np.nan_to_num(gaussian, nan=np.inf))


def extreme(differences: np.ndarray, run_rows: int) -> np.ndarray:
    """Estimate of the largest of ``run_rows`` differences per band from a sample (rows, ..., bands).

    Per band, the sample is pooled with its two neighbouring bands (errors vary smoothly with the
    wavelength, single bands of a few rows do not), then the larger of its largest value and the
    Gaussian expectation of the largest of ``run_rows``: rms x sqrt(2 ln run_rows).
    """
    padded = np.concatenate([differences[..., :1], differences, differences[..., -1:]], axis=-1)
    pooled = np.concatenate([padded[..., :-2], padded[..., 1:-1], padded[..., 2:]], axis=0)
    # NaN marks bands not reported at a candidate: skipped (counted out by hand: numpy's
    # nan-functions warn on NaN-only slices, and a warnings filter is process-wide, which the job's
    # run threads must not touch)
    valid = ~np.isnan(pooled)
    count = valid.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        rms = np.sqrt((np.where(valid, pooled, 0.0) ** 2).sum(axis=0) / count)   # NaN where count is 0
    largest = np.where(count > 0, np.where(valid, pooled, -np.inf).max(axis=0), np.nan)
    return np.fmax(largest, rms * np.sqrt(2.0 * np.log(max(run_rows, 2))))


def richardson(differences: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The finest grid's own error (2, bands) from the differences of its k sequence, and how it was
    judged (2, bands: :data:`MEASURED`, :data:`NOT_MEASURED` or :data:`NOT_CONVERGING`): the line
    pilot's one safety rule (docs/guide/error-budget.md, "The Richardson rule").

    Per level kind and band, with ``last`` = |L(K) - L(K / 2)| and ``before`` = |L(K / 2) - L(K / 4)|
    (each already spread to the run's rows, :func:`extreme`): an error ~ C h^p shrinks
    r = 2^p times per halving and the finest grid's own error is last / (r - 1) (Richardson). r is
    measured per band as before / last and capped at 2^:data:`MAX_ORDER` (a faster shrink is not
    trusted); an order below 1 keeps the larger factor it needs (p = 0.5: 2.4), never clamped up.
    A shrink below :data:`MIN_SHRINK` (or one halving only, order unknown) gets the largest factor
    the rule allows, 1 / (MIN_SHRINK - 1) = 4, and is flagged (the pilot then refines further while
    it may: :func:`reference_converged`); a last difference at most :data:`TINY_DIFFERENCE_DB` is
    the solver's noise, not a trend, and is not flagged.
    """
    last = differences[-1]
    factor = np.full(last.shape, 1.0 / (MIN_SHRINK - 1.0))
    notes = np.full(last.shape, NOT_MEASURED)
    if len(differences) >= 2:
        before = differences[-2]
        with np.errstate(divide="ignore", invalid="ignore"):
            shrink = np.where(last > 0.0, before / last, np.inf)
        shrink = np.nan_to_num(shrink, nan=0.0, posinf=np.inf)
        measured = shrink >= MIN_SHRINK
        factor = np.where(measured, 1.0 / (np.clip(shrink, MIN_SHRINK, 2.0 ** MAX_ORDER) - 1.0), factor)
        notes = np.where(measured, MEASURED, NOT_CONVERGING)
    notes = np.where(last <= TINY_DIFFERENCE_DB, MEASURED, notes)   # below the solver's noise: nothing to judge
    return factor * last, notes


def reference_converged(differences: list[np.ndarray], budget_rows: np.ndarray, budget: float) -> bool:
    """Whether the finest grid's own error (:func:`richardson`) is within :data:`REFERENCE_SHARE` of
    the budget in every budget band (every band when none is one)."""
    error, _ = richardson(differences)
    judged = error[:, budget_rows] if budget_rows.any() else error
    return bool(np.all(np.nan_to_num(judged, nan=0.0) <= REFERENCE_SHARE * budget))


def stated_errors(sequence: dict[int, np.ndarray], candidates: Sequence[int], budget_rows: np.ndarray,
                  run_rows: int, budget: float = DEFAULT_ERROR_BUDGET_DB,
                  max_points: float = np.inf, spread_factor: float = PILOT_SPREAD_FACTOR,
                  sampled: bool = False) -> tuple[dict[int, np.ndarray], np.ndarray, np.ndarray]:
    """The pilot's rule replayed on levels already solved (benches/pilot_calibration.py and the tests):
    ``sequence`` k -> levels (2, pilot rows, bands) at the reference tol on k = 1, 2, 4, ... and on the
    ``candidates``. Returns k -> stated error (bands; worst of the two kinds) for the candidates up to
    the reference's K, the reference's own error (2, bands) and its notes (2, bands)."""
    differences: list[np.ndarray] = []
    k = 1
    while 2 * k in sequence and 2 * k * sequence[1].shape[-1] <= max_points:
        differences.append(run_extreme(sequence[2 * k], sequence[k], run_rows, sampled=sampled))
        k *= 2
        if reference_converged(differences, budget_rows, budget):
            break
    error, notes = richardson(differences) if differences else (np.zeros(sequence[1][:, 0].shape), np.full(
        sequence[1][:, 0].shape, MEASURED))
    stated = {c: (run_extreme(sequence[c], sequence[k], run_rows, spread_factor, sampled) + error).max(axis=0)
              for c in candidates if c <= k}
    return stated, error, notes
