"""Indicators per section of road for a line run: what road agencies report (sections.parquet,
section_bands.parquet), from the run's own MPD baselines and contact-segment band levels.

Sections are consecutive stretches of ``section_length`` (ProcessingOptions.section_length, default
10 m) along the run, in the file's own distances (chainage as the file gives it), starting at the
run's first ISO 13473-1 baseline (the first reading after any reference plate) and ending at the
last whole baseline; the last section is shorter when the run is not a whole number of sections
(``partial``, with a ``note``), and a run shorter than one section gets one partial row.

Per section (sections.parquet, one row per run and section):

- MPD (ISO 13473-1:2019): the mean MSD of the valid 100 mm baselines that start in the section,
  their share of the section's baselines, and validity (at least half of them valid, the
  standard's rule for a measurement); ETD after the edition named (``etd_edition``,
  :func:`~roadtex.profiles.mpd.estimated_texture_depth`).
- Rq, Rsk, Rku of the texture profile (the ISO 13473-2 quantities: root-mean-square height,
  skewness and kurtosis of the height distribution): on the MPD chain's profile (0.5 mm resampling,
  spikes and drop-outs interpolated, the 2.4 mm low-pass of ISO 13473-1 Annex D), each valid
  baseline's least-squares line removed (ISO 13473-1's slope suppression), pooled over the valid
  baselines of the section. ISO 13473-2's own filter prescription could not be read publicly; this
  choice keeps them on the very profile MSD is taken on, and says so.
- Drop-out and spike shares: the mean over the section's baselines of their raw readings missing
  and resampled samples flagged as spikes (ISO 13473-1's per-baseline counts).

Per section, E and band (section_bands.parquet, long form): the energy average
``10 log10(mean(10^(L/10)))`` of the per-segment band levels (original texture, enveloped texture,
pressure; bands.parquet) over the contact segments whose *start* lies in the section (a segment
straddling a section end counts once, where it starts), per modulus. Long form because the bands
differ from run to run (sampling, segment length) and a job solves several moduli: a wide table
would change its columns with the job and could not declare one unit per column; joined to
sections.parquet on (run_id, section).
"""

from __future__ import annotations

import math

import numpy as np
import polars as pl

from roadtex.profiles.mpd import MpdResult, estimated_texture_depth
from roadtex.profiles.trend import remove_lines

SECTION_LEVELS = ("texture_level", "enveloped_level", "pressure_level")


def section_index(positions: np.ndarray, origin: float, section_length: float, count: int) -> np.ndarray:
    """The section (0 .. count - 1) each position (m) starts in; positions within rounding before
    the first section or after the last count to the nearest one (a contact segment starts at a
    sample, a baseline at half a sample earlier)."""
    index = np.floor((np.asarray(positions, dtype=np.float64) - origin) / section_length + 1e-9).astype(np.int64)
    return np.clip(index, 0, count - 1)


def section_table(run_id: str, depth: MpdResult, section_length: float, etd_edition: str = "2019",
                  min_valid_fraction: float = 0.5) -> pl.DataFrame:
    """sections.parquet's rows of one run (SECTION_SCHEMA order) from its MPD result ``depth`` (lengths in m)."""
    baselines = depth.segments
    starts = baselines["start"].to_numpy()
    ends = baselines["end"].to_numpy()
    origin, finish = float(starts[0]), float(ends[-1])
    count = max(1, math.ceil((finish - origin) / section_length - 1e-9))
    section = section_index(starts, origin, section_length, count)
    valid = baselines["valid"].to_numpy()

    points = int(round(float(depth.parameters["segment_length"]) / float(depth.parameters["sample_spacing"])))
    used = starts.size * points
    z, _ = remove_lines(depth.profile.heights[:used].reshape(starts.size, points),
                        depth.profile.positions[:used].reshape(starts.size, points))
    weight = valid.astype(np.float64)
    z2 = z * z   # products, not z ** k: numpy's generic power took 20 ms of a 100 m run's 23
    moments = {k: np.bincount(section, weights=weight * np.sum(power, axis=1), minlength=count)
               for k, power in ((2, z2), (3, z2 * z), (4, z2 * z2))}
    samples = np.bincount(section, weights=weight * points, minlength=count)
    total = np.bincount(section, minlength=count)
    n_valid = np.bincount(section, weights=weight, minlength=count)
    msd_sum = np.bincount(section, weights=np.where(valid, baselines["msd"].to_numpy(), 0.0), minlength=count)
    with np.errstate(invalid="ignore", divide="ignore"):
        mpd = np.where(n_valid > 0, msd_sum / n_valid, np.nan)
        rq = np.sqrt(moments[2] / samples)
        rsk = moments[3] / samples / rq ** 3
        rku = moments[4] / samples / rq ** 4
        share = n_valid / np.maximum(total, 1)
    dropout = np.bincount(section, weights=baselines["dropout_fraction"].to_numpy(), minlength=count) / np.maximum(total, 1)
    spikes = np.bincount(section, weights=baselines["spike_fraction"].to_numpy(), minlength=count) / np.maximum(total, 1)

    s_start = origin + section_length * np.arange(count)
    s_end = np.minimum(s_start + section_length, finish)
    length = s_end - s_start
    partial = length < section_length * (1 - 1e-9)
    notes: list[str | None] = [None] * count
    if partial[-1]:
        notes[-1] = (f"the run ({length[-1]:.4g} m of whole MPD baselines) is shorter than one {section_length:g} m section"
                     if count == 1 else f"the run's last {length[-1]:.4g} m, shorter than a {section_length:g} m section")
    etd = np.array([estimated_texture_depth(m, etd_edition) if np.isfinite(m) else np.nan for m in mpd])
    return pl.DataFrame({
        "run_id": [run_id] * count, "section": np.arange(count), "start": s_start, "end": s_end, "length": length,
        "partial": partial, "note": pl.Series(notes, dtype=pl.String),
        "baselines": total, "valid_baselines": n_valid.astype(np.int64), "valid_baseline_fraction": share,
        "mpd": mpd, "mpd_valid": share >= min_valid_fraction, "etd": etd, "etd_edition": [etd_edition] * count,
        "rq": rq, "rsk": rsk, "rku": rku, "dropout_fraction": dropout, "spike_fraction": spikes,
    }).with_columns(pl.col(c).fill_nan(None) for c in ("mpd", "etd", "rq", "rsk", "rku"))


def section_band_table(sections: pl.DataFrame, bands: pl.DataFrame, segment_starts: np.ndarray,
                       section_length: float) -> pl.DataFrame:
    """section_bands.parquet's rows of one run: per section (``sections``: its :func:`section_table`,
    ``section_length`` in m), E and band, the energy average of the levels (dB) of the contact
    segments (``bands``: the run's bands.parquet rows; ``segment_starts`` in m, by segment number)
    that start in the section, and how many there were (null levels, a band without power or DFT
    line, are left out of the average)."""
    where = section_index(np.asarray(segment_starts), float(sections["start"][0]), section_length, sections.height)
    lookup = pl.DataFrame({"segment": np.arange(len(segment_starts)), "section": where})
    return (bands.join(lookup, on="segment", how="left")
            .group_by("section", "youngs_modulus", "band", maintain_order=True)
            .agg(pl.col("run_id").first(), pl.col("label").first(), pl.col("centre_wavelength").first(),
                 pl.col("reported").first(), pl.col("segment").n_unique().cast(pl.Int64).alias("segments"),
                 *[((10.0 ** (pl.col(c) / 10.0)).mean().log10() * 10.0).alias(c) for c in SECTION_LEVELS])
            .join(sections.select("section", "start", "end"), on="section", how="left")
            .sort("section", "youngs_modulus", "band"))
