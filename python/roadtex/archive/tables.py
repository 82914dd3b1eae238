"""The rows of a run's segment and band tables, built in one place for line and surface runs."""

from __future__ import annotations

from typing import Any

import numpy as np
import polars as pl

from roadtex.archive.schemas import METADATA_COLUMNS, RUN_BAND_SCHEMA, SAMPLING_BAND_COLUMNS, SEGMENT_SCHEMA
from roadtex.profiles.coverage import flat_reason, no_level_reason, too_few_readings
from roadtex.spectra.levels import band_levels

#: The level columns of bands.parquet: NaN (a band without a DFT line) and -inf (a band without power)
#: are undefined numbers, written as null, never as a number that sorts or averages.
LEVEL_COLUMNS = ("texture_level", "enveloped_level", "pressure_level")


def no_level(missing: np.ndarray, what: str, flat: np.ndarray | None = None) -> list[str | None]:
    """Per row, why it has no level, or None: too few readings
    (:func:`roadtex.profiles.coverage.no_level_reason`) or, ``flat`` True, no texture
    (:func:`roadtex.profiles.coverage.flat_reason`)."""
    shares = np.asarray(missing, dtype=np.float64)
    flats = np.zeros(shares.shape, dtype=bool) if flat is None else np.broadcast_to(np.asarray(flat, dtype=bool),
                                                                                    shares.shape)
    return [no_level_reason(float(share), what) if bad else flat_reason(what) if level_less else None
            for share, bad, level_less in zip(shares, too_few_readings(shares), flats)]


def segment_frame(run: dict[str, Any], model: str, segment: np.ndarray, line: np.ndarray | None,
                  modulus: np.ndarray, start: np.ndarray, length: float, mpd: np.ndarray, rms: np.ndarray,
                  measures: dict[str, np.ndarray], residual: np.ndarray, iterations: np.ndarray,
                  converged: np.ndarray, missing: np.ndarray, flat: np.ndarray | None = None) -> pl.DataFrame:
    """Rows of segments.parquet (SEGMENT_SCHEMA), one per (segment, line, modulus) given: the model
    ("line" or "areal"), where each segment starts (m) and its length (m), its MPD (m; NaN: none),
    rms height (m), contact measures and solver outcome, and the share of its samples that had no
    reading (``missing``): over :data:`~roadtex.profiles.coverage.MAX_MISSING_SHARE`, or ``flat``
    (per row: no texture, :func:`roadtex.profiles.coverage.flat_segments`), the segment has no level,
    its contact measures are null and ``no_level_reason`` says why."""
    count = segment.size
    reasons = no_level(missing, "tile" if model == "areal" else "segment", flat)
    measured = np.array([r is None for r in reasons], dtype=bool)
    measures = {k: np.where(measured, np.asarray(v, dtype=np.float64), np.nan) for k, v in measures.items()}
    columns: dict[str, Any] = {
        "run_id": [run["run_id"]] * count, "model": [model] * count, "segment": segment,
        "line": [None] * count if line is None else line, "youngs_modulus": modulus, "start": start,
        "end": start + length, **{name: [run.get(name)] * count for name in METADATA_COLUMNS},
        "mpd": mpd, "rms_height": rms, "missing_fraction": np.asarray(missing, dtype=np.float64),
        "no_level_reason": reasons, **measures, "residual": residual, "iterations": iterations,
        "converged": converged,
    }
    frame = pl.DataFrame({k: (v if isinstance(v, list) else np.asarray(v)) for k, v in columns.items()},
                         schema=SEGMENT_SCHEMA)
    return frame.with_columns(pl.col(c).fill_nan(None) for c in ("mpd", *measures))


def band_frame(run_id: str, model: str, segment: np.ndarray, line: np.ndarray | None, modulus: np.ndarray,
               bands: pl.DataFrame, frequency: np.ndarray, texture: np.ndarray, enveloped: np.ndarray,
               pressure: np.ndarray, missing: np.ndarray, flat: np.ndarray | None = None) -> pl.DataFrame:
    """Rows of bands.parquet (RUN_BAND_SCHEMA), one per (row given, band of ``bands``): ``segment``,
    ``line`` and ``modulus`` per row; ``frequency`` (Hz, NaN without a speed) per band; the texture,
    enveloped and pressure levels (dB) as (rows, bands). A row whose segment has too few readings
    (``missing``, the share of its samples without one, per row), or that is flat (``flat``, per row:
    no texture), has no level: its levels are null, not reported, and ``reason`` says why. The
    sampling statement's columns are null here (a line run's are joined by
    :func:`roadtex.archive.compute.with_sampling`)."""
    rows, n_bands = segment.size, bands.height
    reasons = no_level(missing, "tile" if model == "areal" else "segment", flat)
    measured = np.repeat(np.array([r is None for r in reasons], dtype=bool), n_bands)
    reported = np.tile(bands["reported"].to_numpy(), rows) & measured
    reason = np.where(measured, np.tile(bands["reason"].to_numpy(), rows), np.repeat(np.array(reasons, dtype=object),
                                                                                     n_bands))

    def level(values: np.ndarray) -> np.ndarray:
        return np.where(measured, np.asarray(values, dtype=np.float64).ravel(), np.nan)

    frame = pl.DataFrame({
        "run_id": [run_id] * (rows * n_bands), "model": [model] * (rows * n_bands),
        "segment": np.repeat(segment, n_bands),
        "line": [None] * (rows * n_bands) if line is None else np.repeat(line, n_bands),
        "youngs_modulus": np.repeat(modulus, n_bands),
        "band": np.tile(bands["band"].to_numpy(), rows),
        "label": np.tile(bands["label"].to_numpy(), rows),
        "centre_wavelength": np.tile(bands["centre_wavelength"].to_numpy(), rows),
        "frequency": np.tile(frequency, rows),
        "reported": reported,
        "reason": pl.Series(reason.tolist(), dtype=pl.String),
        "texture_level": level(texture),
        "enveloped_level": level(enveloped),
        "pressure_level": level(pressure),
        **{c: [None] * (rows * n_bands) for c in SAMPLING_BAND_COLUMNS},
    })
    return frame.select([pl.col(c).cast(t) for c, t in RUN_BAND_SCHEMA.items()])


def defined_levels(bands: pl.DataFrame) -> pl.DataFrame:
    """A run's band rows with undefined numbers as null (:data:`LEVEL_COLUMNS`, and a frequency
    without a speed)."""
    return bands.with_columns(pl.col("frequency").fill_nan(None),
                              *[pl.when(pl.col(c).is_finite()).then(pl.col(c)).otherwise(None).alias(c)
                                for c in LEVEL_COLUMNS])


def model_levels(values: np.ndarray, model_dx: float, bands: pl.DataFrame, *, kind: str, method: str,
                 reference: float | None = None) -> np.ndarray:
    """Band levels (rows, bands) of the model's periodic output (rows of enveloped heights in m, or
    pressures in Pa, sampled every ``model_dx`` m) in the data's bands (``bands``, in its order): the
    finer model grid resolves bands the data's do not, which are not the run's to report."""
    extra = {} if reference is None else {"reference": reference}
    levels = band_levels(values, model_dx, kind=kind, periodic=True, method=method, **extra)
    if levels.bands.height == bands.height and levels.bands["band"].equals(bands["band"]):
        return levels.levels   # the data's grid: the same bands
    numbers = levels.bands["band"].to_list()
    return levels.levels[:, [numbers.index(band) for band in bands["band"].to_list()]]
