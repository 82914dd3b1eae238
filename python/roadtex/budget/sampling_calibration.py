"""Building the sampling calibration (issue 33): what a coarse profiler cannot see of the contact
levels, measured on real fine profiles averaged to coarser samplings.

For each fine profile (the CAPTIF files, 0.0375 mm), 0.5 m periodic segments (the job's
conditioning: plates trimmed, spikes removed, seamless segments) are

- solved on their own fine readings, joined linearly and refined :data:`FINE_REFINE` times
  (model dx 0.019 mm: converged, see docs/guide/sampling.md);
- *averaged* to a coarser sampling ``dx``: each reading the mean of the fine road (the fine
  readings joined linearly) over a window of ``width`` centred on it (``width = dx``: interval
  averaging, what ISO 13473-1's resampling does; a smaller ``width`` at a coarser ``dx``: a laser
  spot of that width, sampled every ``dx``), then solved on the coarse readings joined as the job
  joins them (:data:`roadtex.models.grid.DEFAULT_INTERPOLANT`, monotone cubics since 0.5.0) and
  refined until the model dx is at most :data:`MODEL_DX` (converged);

and the difference coarse - fine of their enveloped and pressure band levels is recorded, per
(file, segment, sampling, modulus, band). :func:`summarise` turns those differences into the
table :mod:`roadtex.budget.sampling` states from (bias, within- and between-file scatter).
``benches/sampling_calibration.py`` regenerates the shipped table from the CAPTIF files.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import Sequence

import numpy as np
import polars as pl

from roadtex.budget.noise import budget_bands
from roadtex.errors import InvalidInputError, RoadtexWarning
from roadtex.models.contact import contact_many
from roadtex.models.grid import DEFAULT_INTERPOLANT, Interpolant, refine_periodic
from roadtex.profiles.conditioning import clean
from roadtex.profiles.readers import read_profile
from roadtex.spectra.bands import REFERENCE_PRESSURE
from roadtex.spectra.levels import band_levels

#: Refinement of the fine (0.0375 mm) segments' model grid: 0.019 mm elements.
FINE_REFINE = 2

#: Largest model element (m) of the averaged segments' solves: k = ceil(dx / MODEL_DX).
MODEL_DX = 0.03e-3

#: Solver tolerance of every calibration solve (relative residual).
CALIBRATION_TOL = 1e-8

#: Samplings (dx, averaging width), m: interval averaging at 0.05 to 1 mm, and laser spots of
#: 0.2 mm (a typical triangulation spot; no profiler's figure was found to cite, an assumption)
#: sampled every 0.5 and 1 mm.
DEFAULT_SAMPLINGS: tuple[tuple[float, float], ...] = (
    (0.05e-3, 0.05e-3), (0.1e-3, 0.1e-3), (0.25e-3, 0.25e-3), (0.5e-3, 0.5e-3), (1e-3, 1e-3), (0.5e-3, 0.2e-3), (1e-3, 0.2e-3))

DIFFERENCE_SCHEMA = {
    "file": pl.String, "start": pl.Float64, "dx": pl.Float64, "width": pl.Float64, "youngs_modulus": pl.Float64,
    "band": pl.Int64, "label": pl.String, "centre_wavelength": pl.Float64,
    "enveloped_db": pl.Float64, "pressure_db": pl.Float64,   # coarse - fine
    "fine_enveloped": pl.Float64, "fine_pressure": pl.Float64,   # the fine data's levels (dB re 1 um, re 1 Pa)
}


def periodic_average(heights: np.ndarray, dx: float, points: int, width: float | None = None) -> np.ndarray:
    """Periodic segments (rows, N; m, sampled every ``dx`` m, the road between readings taken as
    linear) read by a coarser profiler: ``points`` readings per period, reading ``j`` at ``j L /
    points`` the mean of the road over a window of ``width`` (m; None: the coarse interval
    ``L / points``) centred on it. Returns (rows, points) heights (m)."""
    z = np.atleast_2d(np.asarray(heights, dtype=np.float64))
    n = z.shape[1]
    length = n * dx
    step = length / points
    w = step if width is None else float(width)
    if not 0 < w < length or points < 8:
        raise InvalidInputError(f"averaging window {w!r} m must be positive and shorter than the segment "
                                f"({length:g} m), with at least 8 readings (got {points})")
    following = np.roll(z, -1, axis=1)
    cell = dx * (z + following) / 2.0                     # trapezoid of each fine interval
    cumulative = np.concatenate([np.zeros((z.shape[0], 1)), np.cumsum(cell, axis=1)], axis=1)
    total = cumulative[:, -1:]

    def integral(x: np.ndarray) -> np.ndarray:
        """Integral of the linear road from 0 to x (any real x, periodic)."""
        wraps = np.floor(x / length)
        u = x - wraps * length
        i = np.minimum((u / dx).astype(np.int64), n - 1)
        t = u / dx - i
        inside = dx * (z[:, i] * t + (following[:, i] - z[:, i]) * t * t / 2.0)
        return wraps * total + cumulative[:, i] + inside

    centres = np.arange(points) * step
    return (integral(centres + w / 2.0) - integral(centres - w / 2.0)) / w


def fine_segments(path: str | Path, segment_length: float = 0.5, step: float = 0.25,
                  spike_alpha: float | None = 3.0) -> tuple[np.ndarray, np.ndarray, float]:
    """A fine profile's seamless periodic segments as the job cuts them (plates trimmed, spikes
    removed, at the file's own interval), starting every ``step`` m: heights (rows, N; m), starts
    (m), dx (m)."""
    if not 0 < step <= segment_length:
        raise InvalidInputError(f"step must be in (0, segment_length], got {step!r} m")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RoadtexWarning)
        profile = read_profile(path)
        cleaned, _ = clean(profile, spike_alpha=spike_alpha, warn=False)
    segments = cleaned.finished(dx=None).segments(segment_length, segment_length - step)
    return segments.heights, segments.starts, segments.dx


def solved_levels(heights: np.ndarray, dx: float, refine: int, moduli: np.ndarray, mean_pressure: float,
                  bands: Sequence[int], interpolant: Interpolant) -> np.ndarray:
    """Enveloped and pressure levels (2, rows, moduli, bands) in dB of periodic segments (rows, N;
    m, every ``dx``) solved on the road through them (``interpolant``) refined ``refine`` times, in
    the band numbers ``bands``."""
    model = refine_periodic(heights, refine, interpolant)
    model_dx = dx / refine
    batch = contact_many(model, model_dx, moduli, mean_pressure, tol=CALIBRATION_TOL, warm_start=True,
                         raise_on_nonconvergence=True)
    rows = heights.shape[0] * moduli.size
    out = []
    for signal, extra in ((batch.envelope, {}), (batch.pressure, {"reference": REFERENCE_PRESSURE})):
        levels = band_levels(signal.reshape(rows, -1), model_dx, periodic=True, **extra)
        numbers = levels.bands["band"].to_list()
        out.append(levels.levels[:, [numbers.index(b) for b in bands]].reshape(heights.shape[0], moduli.size, -1))
    return np.stack(out)


def file_differences(path: str | Path, *, samplings: Sequence[tuple[float, float]] = DEFAULT_SAMPLINGS,
                     youngs_moduli: Sequence[float] = (2e6, 1e7), mean_pressure: float = 2e5,
                     segment_length: float = 0.5, step: float = 0.25, max_segments: int | None = None) -> pl.DataFrame:
    """Differences coarse - fine of the converged enveloped and pressure levels (dB) of one fine
    profile's segments, in the budget bands of the fine data, for every (dx, width) of ``samplings``
    (m) and modulus (Pa); ``max_segments`` keeps that many segments, spread evenly along the run.
    Rows: :data:`DIFFERENCE_SCHEMA`."""
    heights, starts, dx = fine_segments(path, segment_length, step)
    if max_segments is not None and heights.shape[0] > max_segments:
        keep = np.unique(np.round(np.linspace(0, heights.shape[0] - 1, max_segments)).astype(np.int64))
        heights, starts = heights[keep], starts[keep]
    length = heights.shape[1] * dx
    moduli = np.asarray(youngs_moduli, dtype=np.float64)
    table = budget_bands(dx, length)
    bands = table["band"].to_list()
    fine = solved_levels(heights, dx, FINE_REFINE, moduli, mean_pressure, bands, "linear")   # the fine data's own road
    frames = []
    for coarse_dx, width in samplings:
        points = int(round(length / coarse_dx))
        coarse = periodic_average(heights, dx, points, width)
        step_dx = length / points
        refine = max(1, math.ceil(step_dx / MODEL_DX * (1.0 - 1e-9)))
        levels = solved_levels(coarse, step_dx, refine, moduli, mean_pressure, bands, DEFAULT_INTERPOLANT)
        diff = levels - fine
        rows = heights.shape[0] * moduli.size * len(bands)
        frames.append(pl.DataFrame({
            "file": [Path(path).name] * rows,
            "start": np.repeat(starts, moduli.size * len(bands)),
            "dx": np.full(rows, coarse_dx), "width": np.full(rows, width),
            "youngs_modulus": np.tile(np.repeat(moduli, len(bands)), heights.shape[0]),
            "band": np.tile(bands, heights.shape[0] * moduli.size),
            "label": np.tile(table["label"].to_numpy(), heights.shape[0] * moduli.size),
            "centre_wavelength": np.tile(table["centre_wavelength"].to_numpy(), heights.shape[0] * moduli.size),
            "enveloped_db": diff[0].ravel(), "pressure_db": diff[1].ravel(),
            "fine_enveloped": fine[0].ravel(), "fine_pressure": fine[1].ravel(),
        }, schema=DIFFERENCE_SCHEMA))
    return pl.concat(frames)



def energetic_mean(levels: np.ndarray) -> float:
    """Mean of levels (dB) in power, as the report averages a run's segments."""
    return float(10.0 * np.log10(np.mean(10.0 ** (np.asarray(levels) / 10.0))))


def run_segments(starts: np.ndarray, segment_length: float) -> np.ndarray:
    """Which of (possibly overlapping) segment ``starts`` (m) a job would cut: every
    ``segment_length`` from the first, without overlap."""
    offsets = (starts - starts.min()) / segment_length
    return np.abs(offsets - np.round(offsets)) < 1e-6


def leave_one_out(differences: pl.DataFrame, *, level: str = "enveloped", correct: bool = False,
                  segment_length: float = 0.5, long_run: bool = False) -> pl.DataFrame:
    """Each file of ``differences`` (:func:`file_differences`, several files) predicted from a
    calibration of the others (:func:`roadtex.budget.sampling.summarise`): per (file, dx, width,
    modulus, band) the actual difference of the run's mean level (the energetic mean over the
    file's non-overlapping segments, as the report averages; minus the correction when
    ``correct``) from the fine data's, the stated run-mean uncertainty, ``covered``
    (|actual| <= stated), and ``segments_covered``: the share of the file's segments (all of them,
    overlapping ones too) whose own difference the single-segment uncertainty covers. ``long_run``:
    the long-run limit instead, the mean over every segment of the file (overlapping ones too)
    against the statement for infinitely many segments (what the calibration itself knows: the
    between-file scatter and the bias's own standard error)."""
    from roadtex.budget.sampling import sampling_statement, summarise

    files = sorted(set(differences["file"].to_list()))
    if len(files) < 2:
        raise InvalidInputError("leave-one-out needs differences of at least two files")
    rows = []
    for held in files:
        table = summarise(differences.filter(pl.col("file") != held), level, segment_length)
        every = differences.filter(pl.col("file") == held)
        starts = np.unique(every["start"].to_numpy())
        run = starts if long_run else starts[run_segments(starts, segment_length)]
        test = every.filter(pl.col("start").is_in(run.tolist()))
        moduli = np.unique(test["youngs_modulus"].to_numpy())
        for (dx, width), case in test.group_by(["dx", "width"], maintain_order=True):
            statement = sampling_statement(dx, moduli, np.inf if long_run else run.size, correct=correct, table=table,
                                           level=level,
                                           width=None if dx == width else width)
            for (modulus, band), cell in case.group_by(["youngs_modulus", "band"], maintain_order=True):
                fine = cell[f"fine_{level}"].to_numpy()
                actual = energetic_mean(fine + cell[f"{level}_db"].to_numpy()) - energetic_mean(fine)
                said = statement.filter((pl.col("youngs_modulus") == modulus) & (pl.col("band") == band))
                correction = said["sampling_correction_db"][0] if correct else None
                actual -= correction or 0.0
                stated = said["sampling_run_uncertainty_db"][0]
                single = every.filter((pl.col("dx") == dx) & (pl.col("width") == width)
                                      & (pl.col("youngs_modulus") == modulus) & (pl.col("band") == band))
                own = (single[f"{level}_db"].to_numpy() - (correction or 0.0))
                rows.append({"file": held, "dx": dx, "width": width, "youngs_modulus": modulus, "band": band,
                             "label": cell["label"][0], "actual_db": actual, "stated_db": stated,
                             "covered": abs(actual) <= stated,
                             "segments_covered": float(np.mean(np.abs(own) <= said["sampling_uncertainty_db"][0]))})
    return pl.DataFrame(rows)
