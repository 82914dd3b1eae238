"""One run of the bulk job: read, condition, segment, solve, spectra; its tables, nothing written."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import numpy as np
import polars as pl

from roadtex.archive.options import DEFAULT_TOL, MAX_SEGMENT_MODEL_POINTS, ProcessingOptions
from roadtex.archive.plan import JobPlan
from roadtex.archive.reading import reader_options
from roadtex.archive.schemas import EXAMPLE_SCHEMA, PROFILE_SCHEMA, RUN_BAND_SCHEMA, RUN_RUN_SCHEMA
from roadtex.archive.sections import section_band_table, section_table
from roadtex.archive.tables import band_frame, defined_levels, model_levels, segment_frame
from roadtex.budget.sampling import STATEMENT_SCHEMA, run_statement
from roadtex.errors import ArchiveWriteError, InvalidInputError, RunFailure
from roadtex.models.contact import contact_many
from roadtex.models.grid import coarse_points, reading_means, refine_periodic
from roadtex.models.results import ContactBatch
from roadtex.profiles.conditioning import CleaningSummary, clean
from roadtex.profiles.coverage import flat_segments, height_scale, missing_shares, too_few_readings
from roadtex.profiles.mpd import mpd as mean_profile_depth
from roadtex.profiles.plausibility import (
    PLAUSIBLE_MAX_DX,
    coarse_sampling,
    implausible_texture,
    judged_once,
    stated_distance_unit,
)
from roadtex.profiles.profile import Profile
from roadtex.profiles.readers import read_profile
from roadtex.profiles.units import unit_factor
from roadtex.spectra.analysis import time_frequency
from roadtex.spectra.bands import REFERENCE_PRESSURE, band_table
from roadtex.spectra.levels import band_levels

#: Model grid points solved per call of the Rust core (every segment of a chunk, one modulus): bounds
#: memory on long runs whatever the model grid's k (the envelopes and pressures of every modulus
#: are kept for the chunk: 4 moduli x 2 arrays x 8 bytes x 2^22 points = 256 MB).
CHUNK_MODEL_POINTS = 1 << 22


def run_stage(stage: str, action: Callable[[], Any]) -> Any:
    """``action()``, any failure of it recorded as this run's failure at ``stage``.

    A panic inside any extension module (polars, pyo3-based libraries: a PanicException, which is a
    BaseException) is that run's failure too, so one bad file never stops the job. What must stop
    the job still does: a failure to write output, running out of memory (except while reading the
    file: what a file holds is that run's failure), Ctrl-C, interpreter exit.
    """
    try:
        return action()
    except MemoryError as exc:
        if stage != "read":
            raise
        # what a file holds (or claims to) is that run's failure: one file never stops the job
        raise RunFailure(stage, MemoryError(f"reading the file needs more memory than is free ({exc})")) from exc
    except (ArchiveWriteError, KeyboardInterrupt, SystemExit, GeneratorExit):
        raise
    except BaseException as exc:  # noqa: BLE001 - see the docstring: panics are BaseExceptions
        raise RunFailure(stage, exc) from exc


def compute_run(run: dict[str, Any], plan: JobPlan | ProcessingOptions, *,
                threads: int | None = None) -> dict[str, Any]:
    """Reads, cleans, conditions, segments, solves and analyses one line run as ``plan`` says; returns
    its tables (nothing written), its plan entry (``plan_entry``, a
    :class:`~roadtex.archive.plan.RunPlan`) and its notes on plausibility (strings or None, see
    :func:`plausibility_notes`).

    The run is solved on its own readings (at its own interval, or coarser where its group's pilot
    averaged them down: :meth:`~roadtex.archive.plan.JobPlan.line_entry`), on a model grid k times
    finer (the readings joined by the entry's interpolant, :mod:`roadtex.models.grid`); its
    enveloped and pressure levels are taken on that grid in the data's bands; texture levels are
    the data's. ``plan`` may be bare :class:`ProcessingOptions` (:meth:`JobPlan.given`: no pilot).
    The plan's error estimates are added when the job combines the runs' tables
    (:func:`roadtex.archive.combined.combine`).

    Raises:
        RunFailure: with the stage that failed (read, condition, mpd, segment, spectra, solve). A run
            too short for one 100 mm MPD baseline or one segment fails as a whole, and so does a
            file whose heights cannot be a road texture in the unit read (a unit mistake), unless
            ``options.allow_implausible`` (:func:`plausibility_notes`).
    """
    plan = plan if isinstance(plan, JobPlan) else JobPlan.given(plan)
    options = plan.options
    name = Path(run["path"]).name
    reading = reader_options(run, options)
    # judged here, and refused: no warning from the reader that it computes as given
    with judged_once():
        raw = run_stage("read", lambda: read_profile(run["path"], format=run.get("format"), **reading))
    notes = plausibility_notes(raw.heights, raw.dx, name, raw.metadata, options, given_dx=reading.get("dx"),
                               given_unit=reading.get("distance_unit"))
    entry = plan.line_entry(run, raw.dx)
    cleaned, cleaning = run_stage("condition", lambda: clean_quietly(raw, options.spike_alpha, name))
    # its own readings (resampling at its own interval is the identity), or averaged down
    coarser = entry.data_dx if entry.data_dx is not None and entry.data_dx > raw.dx else None
    # Profile.finished's steps, with the samples that had no reading kept apart: a segment mostly filled
    # has no level (roadtex.profiles.coverage)
    resampled = run_stage("condition", lambda: cleaned.resample(cleaned.dx if coarser is None else coarser))
    conditioned = run_stage("condition", lambda: resampled.fill_dropouts().detrend("linear"))
    missing = np.isnan(resampled.heights)
    depth = run_stage("mpd", lambda: mean_profile_depth(raw, spike_alpha=options.mpd_spike_alpha))
    if conditioned.length < options.segment_length:
        trimmed = f", {cleaning.trimmed_length:.3g} m of reference plates trimmed" if cleaning.trimmed_length > 0 else ""
        raise RunFailure("segment", InvalidInputError(
            f"{name}: the run is {conditioned.length:.4g} m long{trimmed}, shorter than one segment of "
            f"{options.segment_length:g} m: process it with a --segment-length (ProcessingOptions.segment_length) "
            f"of at most {conditioned.length:.4g} m, in a job of its own if the other runs keep theirs"))
    segments = run_stage("segment", lambda: conditioned.segments(options.segment_length, options.segment_overlap))
    n_segments, n_points = segments.heights.shape
    shares = missing_shares(missing, segments.start_indices, n_points)
    # a segment of readings on a straight line (a plate, a held reading) has no texture: no level
    flat = flat_segments(segments.heights, height_scale(resampled.heights))
    refine, tol = int(entry.refine or 1), float(entry.tol or DEFAULT_TOL)
    if n_points * refine > MAX_SEGMENT_MODEL_POINTS:
        raise RunFailure("segment", InvalidInputError(
            f"{name}: a model grid {refine} times finer than its {n_points} readings a segment would have "
            f"{n_points * refine:,} points a segment, above {MAX_SEGMENT_MODEL_POINTS:,}: use a smaller --refine "
            "or shorter segments (--segment-length)"))
    moduli = np.asarray(options.youngs_moduli)
    n_moduli = moduli.size
    dx = segments.dx
    model_dx = dx / refine
    speed = run.get("speed_kmh")
    speed = options.speed_kmh if speed is None or not np.isfinite(speed) else speed

    baselines = depth.segments
    mpd_per_segment = segment_mpd(baselines, segments.starts, segments.length, max(dx, 5e-4))

    segment_frames: list[pl.DataFrame] = []
    band_frames: list[pl.DataFrame] = []
    profile_envelopes = np.empty((n_moduli, n_segments, n_points)) if options.keep_profiles else None
    profile_pressures = np.empty((n_moduli, n_segments, n_points)) if options.keep_profiles else None
    # The contact model sees each segment as one period, so the original segments are analysed
    # the same way as its (periodic) output: exact DFT band powers, no window. Differences
    # enveloped - original then come from the envelopment alone, not from a change of method.
    # The segments are seamless (Profile.segments removes the line through each one's ends), so
    # neither sees a step at the wrap that the texture does not have.
    kind, method = options.band_kind, options.band_method
    texture = run_stage("spectra", lambda: band_levels(segments.heights, dx, kind=kind, periodic=True, method=method))
    if not texture.bands["reported"].any():
        raise RunFailure("spectra", InvalidInputError(
            f"no {kind.replace('_', '-')} band is allowed by the sampling ({dx:.3g} m) and the "
            f"segment length ({segments.length:.3g} m); use longer segments"))
    # Every candidate band is kept, with its reported flag and the reason when it is not reported.
    bands = texture.bands
    frequency = (run_stage("spectra", lambda: time_frequency(bands["centre_wavelength"].to_numpy(), speed))
                 if speed is not None else np.full(bands.height, np.nan))

    # The report draws its profile figures from this segment's own solves (it never re-solves).
    example_segment = n_segments // 2
    example = None
    # segments solved per call of the Rust core: memory bounded by model points, whatever k
    chunk_segments = max(1, CHUNK_MODEL_POINTS // (n_points * refine))
    for first in range(0, n_segments, chunk_segments):
        chunk = slice(first, min(first + chunk_segments, n_segments))
        heights = segments.heights[chunk]
        model = refine_periodic(heights, refine, entry.interpolant)   # heights itself when refine is 1
        batch = run_stage("solve", lambda: contact_many(
            model, model_dx, moduli, options.mean_pressure, poisson=options.poisson, tol=tol,
            max_iterations=options.max_iterations, threads=threads, warm_start=True,
            raise_on_nonconvergence=False))
        count = heights.shape[0]
        model_points = model.shape[1]
        envelopes = batch.envelope.reshape(count * n_moduli, model_points)
        pressures = batch.pressure.reshape(count * n_moduli, model_points)
        enveloped = run_stage("spectra", lambda: model_levels(envelopes, model_dx, bands, kind=kind, method=method))
        pressure = run_stage("spectra", lambda: model_levels(pressures, model_dx, bands, kind=kind, method=method,
                                                             reference=REFERENCE_PRESSURE))
        if options.keep_profiles:   # at the data's readings, as the profile is
            profile_envelopes[:, chunk] = np.moveaxis(coarse_points(batch.envelope, refine), 1, 0)
            # the pressure on each reading's interval (its mean there): the load kept, not the tops' peaks
            profile_pressures[:, chunk] = np.moveaxis(reading_means(batch.pressure, refine), 1, 0)
        if first <= example_segment < first + count:
            example = example_table(run["run_id"], segments, example_segment, moduli, batch, example_segment - first,
                                    model[example_segment - first], model_dx)
        seg_index = np.repeat(np.arange(first, first + count), n_moduli)
        mod_index = np.tile(np.arange(n_moduli), count)
        segment_frames.append(segment_frame(
            run, "line", seg_index, None, moduli[mod_index], segments.starts[seg_index], segments.length,
            mpd_per_segment[seg_index], heights.std(axis=1)[seg_index - first],
            {key: values.ravel() for key, values in batch.measures().items()}, batch.residual.ravel(),
            batch.iterations.ravel(), batch.converged.ravel(), shares[seg_index], flat[seg_index]))
        band_frames.append(band_frame(run["run_id"], "line", seg_index, None, moduli[mod_index], bands, frequency,
                                      texture.levels[seg_index], enveloped, pressure, shares[seg_index],
                                      flat[seg_index]))

    measured = int((~too_few_readings(shares) & ~flat).sum())   # the segments with a level: what a run mean averages
    statement, sampling_dx, resolved_to = run_stage("spectra", lambda: run_statement(
        raw.dx, dx, conditioned.length * measured / n_segments, options.segment_length, max(measured, 1), moduli,
        options.mean_pressure,
        options.band_kind, options.band_method, dict(bands.select("band", "centre_wavelength").iter_rows()),
        correct=options.sampling_correction))
    tables: dict[str, Any] = {
        "plan_entry": entry,
        "example": example,
        "segments": pl.concat(segment_frames),
        "bands": defined_levels(with_sampling(pl.concat(band_frames), statement)),
        "run": run_row(run, raw, conditioned, cleaning, depth, n_segments, tol, refine).with_columns(
            pl.lit(sampling_dx, dtype=pl.Float64).alias("sampling_dx"),
            pl.lit(resolved_to, dtype=pl.Float64).alias("contact_resolved_to")),
    }
    sections = run_stage("mpd", lambda: section_table(run["run_id"], depth, options.section_length, options.etd_edition))
    tables["sections"] = sections
    tables["section_bands"] = run_stage("spectra", lambda: section_band_table(
        sections, tables["bands"], segments.starts, options.section_length))
    if options.keep_profiles:
        tables["profiles"] = stitched_profiles(run["run_id"], segments, moduli, profile_envelopes, profile_pressures)
    return {**tables, **notes}


def resolves_a_band(dx: float, length: float, kind: str) -> bool:
    """Whether a segment ``length`` (m) sampled every ``dx`` (m) reports any band of ``kind``
    (one of fewer than 8 samples reports none)."""
    try:
        return bool(band_table(dx, length, kind)["reported"].any())
    except InvalidInputError:   # too few samples for a spectrum
        return False


#: Where a user allows what plausibility refuses (the message's last words).
ALLOW_IMPLAUSIBLE = "--allow-implausible (ProcessingOptions.allow_implausible) processes it as read"


def plausibility_notes(heights: np.ndarray, dx: float, name: str, metadata: dict[str, Any], options: ProcessingOptions,
                       *, given_dx: object = None, given_unit: object = None,
                       row: str = "segment") -> dict[str, str | None]:
    """Judges a run's heights (m; rows of ``row``) and interval ``dx`` (m) as read from file ``name``
    (``metadata``: the reader's, which says whether the distances' unit is certain): raises the run's
    failure at "read" when they cannot be road texture in metres (a unit mistake, with what to do),
    unless ``options.allow_implausible``; else returns the notes the job warns with after the runs
    (:func:`roadtex.archive.job.process`): ``implausible_note`` (processed as read although
    implausible) and ``sampling_note`` (an interval above PLAUSIBLE_MAX_DX, processed), each None
    when there is nothing to say. A file whose distance unit is certain is never refused for its
    interval alone; a file sampled so coarsely that no band of a segment is resolved is refused
    (nothing could be reported), whatever its unit. ``given_dx`` and ``given_unit`` are the dx (m)
    and distance_unit given for the file, which a refusal quotes."""
    stated = stated_distance_unit(metadata)
    reason = implausible_texture(heights, dx, name, row=row, interval_stated=stated is not None)
    if reason is not None and not options.allow_implausible:
        if given_dx is not None and dx > PLAUSIBLE_MAX_DX:
            what = (f"The interval dx = {given_dx:g} given for it (manifest column dx, --input-dx) must be in "
                    "metres (0.5 mm is 0.5e-3); if it is, distance_unit m for the file (manifest column, "
                    "--distance-unit) states so.") + dx_unit_note(given_dx, given_unit)
        else:
            what = ("Give the file's units (manifest columns distance_unit, height_unit; --distance-unit, "
                    "--height-unit) where its header states none; a unit its header states wrongly must be "
                    "corrected in the file (a unit given never overrides the header's).")
        raise RunFailure("read", InvalidInputError(f"{reason} {what} If the file is right as read, {ALLOW_IMPLAUSIBLE}."))
    note = coarse_sampling(dx, name, stated)
    if note is not None and not resolves_a_band(dx, options.segment_length, options.band_kind):
        # nothing its sampling resolves: solving it would report nothing (a 0.5 m interval is
        # usually distances in mm given as m, whatever unit was stated)
        unit = f"its distances' unit: {stated}" if stated else "its distances read as metres"
        raise RunFailure("read", InvalidInputError(
            f"{name}: sampled every {dx:.4g} m ({unit}), which resolves no {options.band_kind.replace('_', '-')} "
            f"band of segments of {options.segment_length:g} m (a band needs 2.5 samples a wavelength and 12 "
            "wavelengths a segment): nothing could be reported. Were its distances in millimetres? Give the unit "
            "that is right (manifest column distance_unit, --distance-unit; a header's unit must be corrected in "
            "the file), or longer segments (--segment-length)."))
    return {"implausible_note": None if reason is None else f"{reason} Processed as read (--allow-implausible).",
            "sampling_note": note}


def dx_unit_note(given_dx: object, given_unit: object) -> str:
    """What a refusal of a given dx (m) says of a distance_unit other than m given with it: it is the
    unit of a file's distances, never of a bare dx (the dx in metres it meant, if it meant that)."""
    if not isinstance(given_unit, str) or not isinstance(given_dx, (int, float)):
        return ""
    try:
        factor = unit_factor(given_unit, "the distances")
    except InvalidInputError:
        return ""
    if factor == 1.0:
        return ""
    return (f" The distance_unit {given_unit!r} given with it is the unit of a file's distances, not of dx (in metres "
            f"whatever distance_unit says): {given_dx:g} {given_unit} is dx {given_dx * factor:g}.")


def with_sampling(bands: pl.DataFrame, statement: pl.DataFrame) -> pl.DataFrame:
    """A run's band rows (RUN_BAND_SCHEMA) with its sampling statement
    (:func:`roadtex.budget.sampling.run_statement`, joined on modulus and band; null where it has
    none) and its correction, if any, subtracted from ``enveloped_level``."""
    columns = [c for c in STATEMENT_SCHEMA if c not in ("youngs_modulus", "band")]
    joined = bands.drop(columns).join(statement, on=["youngs_modulus", "band"], how="left", maintain_order="left")
    return joined.with_columns(
        (pl.col("enveloped_level") - pl.col("sampling_correction_db").fill_null(0.0)).alias("enveloped_level")
    ).select(list(RUN_BAND_SCHEMA))


def clean_quietly(raw: Profile, spike_alpha: float | None, name: str) -> tuple[Profile, CleaningSummary]:
    """:func:`clean` with its warnings recorded in the summary (and runs.parquet) instead of printed
    from worker threads, where they would interleave with the progress bar."""
    return clean(raw, spike_alpha=spike_alpha, name=name, warn=False)


def run_row(run: dict[str, Any], raw: Profile, conditioned: Profile, cleaning: CleaningSummary, depth: Any,
              n_segments: int, tol: float, refine: int) -> pl.DataFrame:
    """The run's row of runs.parquet: what was read, removed and solved, and its MPD with validity
    (the plan's columns are added when the job combines the runs)."""
    mpd_value = depth.mpd if np.isfinite(depth.mpd) else None
    return pl.DataFrame({
        "run_id": [run["run_id"]], "path": [run["path"]], "format": [run.get("format")],
        "file_dx": [raw.dx], "dx_used": [conditioned.dx], "tol_used": [tol], "refine": [refine],
        "model_dx": [conditioned.dx / refine], "points": [conditioned.heights.size],
        "raw_length": [cleaning.raw_length], "trimmed_length": [cleaning.trimmed_length],
        "length": [conditioned.length], "plates": [cleaning.plates],
        "dropout_fraction": [cleaning.dropout_fraction], "spike_fraction": [cleaning.spike_fraction],
        "outlier_fraction": [cleaning.outlier_fraction],
        "conditioning_warnings": ["; ".join(cleaning.warnings) or None],
        "segments": [n_segments], "sampling_dx": [None], "contact_resolved_to": [None],
        "mpd": [mpd_value], "mpd_valid": [bool(depth.is_valid)],
        "mpd_valid_baselines": [int(depth.valid_segments)], "mpd_baselines": [int(depth.segments.height)],
        "refine_across": [None], "model_dy": [None],   # a line run's model grid is along the road only
        "mpd_spike_rejected": [depth.rejected["spikes"]], "mpd_dropout_rejected": [depth.rejected["dropouts"]],
        "mpd_rejections": [depth.rejection_note()],
    }, schema=RUN_RUN_SCHEMA)


def segment_mpd(baselines: pl.DataFrame, starts: np.ndarray, length: float, dx: float) -> np.ndarray:
    """Mean of the valid ISO baselines lying inside each segment, to within one sample (NaN where none)."""
    valid = baselines.filter(pl.col("valid")).sort("start")
    b_start = valid["start"].to_numpy()
    b_end = valid["end"].to_numpy()
    cumulative = np.concatenate([[0.0], np.cumsum(valid["msd"].to_numpy())])
    # Segments start at a sample, baselines at a sample interval's edge (half a sample earlier),
    # and the two grids may differ (MPD resamples to 0.5 mm): allow one sample either way.
    slack = dx
    # Baselines have equal lengths, so sorting by start sorts the ends too.
    first = np.searchsorted(b_start, starts - slack, side="left")
    last = np.searchsorted(b_end, starts + length + slack, side="right")
    count = np.maximum(last - first, 0)
    out = np.full(starts.size, np.nan)
    has = count > 0
    out[has] = (cumulative[last[has]] - cumulative[first[has]]) / count[has]
    return out


def stitched_profiles(run_id: str, segments: Any, moduli: np.ndarray, envelopes: np.ndarray,
                       pressures: np.ndarray) -> pl.DataFrame:
    frames = []
    heights_positions, heights = segments.stitch(segments.heights, add_trend=True)
    for k, modulus in enumerate(moduli):
        _, envelope = segments.stitch(envelopes[k], add_trend=True)
        _, pressure = segments.stitch(pressures[k])
        frames.append(pl.DataFrame({
            "run_id": [run_id] * heights.size, "youngs_modulus": np.full(heights.size, modulus),
            "position": heights_positions, "height": heights, "envelope": envelope, "pressure": pressure,
        }, schema=PROFILE_SCHEMA))
    return pl.concat(frames)


def example_table(run_id: str, segments: Any, segment: int, moduli: np.ndarray, batch: ContactBatch,
                  row: int, model_heights: np.ndarray, model_dx: float) -> pl.DataFrame:
    """One segment's heights as solved (on the model's grid, ``model_dx`` m), envelopes and
    pressures for every modulus (EXAMPLE_SCHEMA)."""
    n_points = model_heights.size
    positions = segments.starts[segment] + model_dx * np.arange(n_points)
    return pl.DataFrame({
        "run_id": [run_id] * (moduli.size * n_points),
        "segment": np.full(moduli.size * n_points, segment),
        "youngs_modulus": np.repeat(moduli, n_points),
        "dx": np.full(moduli.size * n_points, model_dx),
        "position": np.tile(positions, moduli.size),
        "height": np.tile(model_heights, moduli.size),
        "envelope": batch.envelope[row].ravel(),
        "pressure": batch.pressure[row].ravel(),
    }, schema=EXAMPLE_SCHEMA)
