"""Indicators per section of road for a line run: what road agencies report (sections.parquet,
section_bands.parquet), from the run's own MPD baselines and contact-segment band levels.

Sections are consecutive stretches of ``section_length`` (ProcessingOptions.section_length, default
10 m, at least the 100 mm MPD baseline: a shorter section would hold no MPD) along the run, in the
file's own distances (chainage as the file gives it), from the run's start (its first reading
after any reference plate: a 1 mm file from 0 m reads 0-10 m, 10-20 m; 0.3.0 started half a
reading earlier, at the first baseline's edge) to its last whole ISO 13473-1 baseline. A baseline
belongs to the section it starts in, counted along the baselines' own chain (which starts half a
reading before the first reading: each reading stands for the interval around it). The last
section is shorter when the run is not a whole number of sections (``partial``, with a
``note``), and a run shorter than one section gets one partial row.

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

from roadtex.errors import InvalidInputError
from roadtex.profiles.mpd import MpdResult, estimated_texture_depth
from roadtex.profiles.plausibility import PLAUSIBLE_MAX_DX
from roadtex.profiles.trend import remove_lines

#: The ISO 13473-1 MPD baseline (m): the shortest section that can hold an MPD.
MPD_BASELINE = 0.1

#: How far (m) before the run's first reading a contact segment may start and count in the first
#: section: within that reading's interval (the job's samples are interval centres, so at a dx
#: finer than the file's the first starts up to half a reading early), half the coarsest plausible
#: interval (roadtex.profiles.plausibility.PLAUSIBLE_MAX_DX). Earlier is refused.
START_TOLERANCE = PLAUSIBLE_MAX_DX / 2

SECTION_LEVELS = ("texture_level", "enveloped_level", "pressure_level")


def section_index(positions: np.ndarray, origin: float, section_length: float, count: int,
                  tolerance: float = 0.0) -> np.ndarray:
    """The section (0 .. count - 1) each position (m) starts in, sections of ``section_length`` from
    ``origin``. A position up to ``tolerance`` (m) before the first section counts in it (a contact
    segment or baseline starting within the run's first reading's interval); any other position
    outside the sections is refused, never moved into the nearest one.

    Raises:
        InvalidInputError: a position outside the sections (or not finite).
    """
    at = np.asarray(positions, dtype=np.float64)
    index = np.floor((at - origin) / section_length + 1e-9)
    early = (index < 0) & (at >= origin - tolerance - 1e-9 * section_length)
    index = np.where(early, 0.0, index)
    outside = ~np.isfinite(index) | (index < 0) | (index > count - 1)
    if outside.any():
        first = float(at[outside][0])
        raise InvalidInputError(
            f"{int(outside.sum())} position(s) (the first at {first:g} m) lie outside the run's {count} section(s) of "
            f"{section_length:g} m from {origin:g} m: they belong to no section")
    return index.astype(np.int64)


def section_table(run_id: str, depth: MpdResult, section_length: float, etd_edition: str = "2019",
                  min_valid_fraction: float = 0.5) -> pl.DataFrame:
    """sections.parquet's rows of one run (SECTION_SCHEMA order) from its MPD result ``depth`` (lengths in m)."""
    if not (isinstance(section_length, (int, float, np.floating)) and not isinstance(section_length, bool)
            and math.isfinite(section_length)
            and section_length >= MPD_BASELINE * (1 - 1e-9)):
        raise InvalidInputError(f"section_length must be at least the {MPD_BASELINE * 1e3:g} mm MPD baseline "
                                f"(ISO 13473-1; a shorter section holds no MPD) and finite, got {section_length!r} m")
    baselines = depth.segments
    starts = baselines["start"].to_numpy()
    ends = baselines["end"].to_numpy()
    chain, finish = float(starts[0]), float(ends[-1])
    # chainage from the run's first reading; the baselines' chain starts half a reading before it
    origin = chain if depth.first_reading is None else float(depth.first_reading)
    count = max(1, math.ceil((finish - chain) / section_length - 1e-9))
    section = section_index(starts - chain, 0.0, section_length, count)
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
    s_end = np.minimum(s_start + section_length, origin + (finish - chain))
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
    where = section_index(np.asarray(segment_starts), float(sections["start"][0]), section_length, sections.height,
                          tolerance=START_TOLERANCE)
    unknown = sorted(set(bands["segment"].unique().to_list()) - set(range(len(segment_starts))))
    if unknown:   # a row without a start would land in no section (a null one)
        raise InvalidInputError(f"band rows of segment(s) {unknown[:5]} have no segment start (of {len(segment_starts)})")
    lookup = pl.DataFrame({"segment": np.arange(len(segment_starts)), "section": where})
    return (bands.join(lookup, on="segment", how="left")
            .group_by("section", "youngs_modulus", "band", maintain_order=True)
            .agg(pl.col("run_id").first(), pl.col("label").first(), pl.col("centre_wavelength").first(),
                 pl.col("reported").first(), pl.col("segment").n_unique().cast(pl.Int64).alias("segments"),
                 *[((10.0 ** (pl.col(c) / 10.0)).mean().log10() * 10.0).alias(c) for c in SECTION_LEVELS])
            .join(sections.select("section", "start", "end"), on="section", how="left")
            .sort("section", "youngs_modulus", "band"))
