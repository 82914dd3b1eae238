"""The seed's statements (the INRETS report), each checked by one call on any profiles:

- :func:`penetration_ranking` (figure 4.3): in which E interval the von Meier penetration lies, for the
  narrowest and the widest valleys;
- :func:`depth_effect` (figure 4.4): whether envelopment removes porous asphalt's "depth effect" (its
  texture levels above a dense surface's) across the bands;
- :func:`pressure_texture_fits` (figure 4.6): the linear relation between pressure and enveloped
  texture levels per band and E: slope, intercept and scatter.

Each returns a :class:`SeedCheck`: the data behind the figure, a summary table and whether the seed's
statement holds on these profiles. Units are SI (m, Pa), levels in dB (texture re 1 um, pressure re 1 Pa).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import polars as pl

from roadtex._checks import as_float_array, positive, to_float
from roadtex.comparisons.figures import SEED_D_STAR, valley_penetration
from roadtex.errors import InvalidInputError
from roadtex.models.contact import contact_many
from roadtex.profiles.trend import remove_end_lines
from roadtex.spectra.analysis import band_regressions
from roadtex.spectra.bands import REFERENCE_PRESSURE, BandKind
from roadtex.spectra.levels import Method, band_levels

SEED_MODULI = (1e6, 2e6, 5e6, 1e7)
"""The moduli of the seed's figures 4.3 to 4.6, 1, 2, 5 and 10 N/mm^2, in Pa."""


@dataclass(frozen=True)
class SeedCheck:
    """One of the seed's statements checked.

    Attributes:
        data: the tidy table behind the figure (one observation per row).
        summary: the table the statement is read from.
        holds: whether the seed's statement holds on these profiles (see each function for the test).
        statement: the seed's statement, in words.
    """

    data: pl.DataFrame
    summary: pl.DataFrame
    holds: bool
    statement: str


# --------------------------------------------------------------------------------------------------
# Figure 4.3: von Meier against INRETS penetration, by valley width
# --------------------------------------------------------------------------------------------------

def penetration_ranking(heights: np.ndarray | Sequence[float], dx: float, *,
                        youngs_moduli: Sequence[float] = SEED_MODULI, mean_pressure: float = 2e5,
                        d_star: float = SEED_D_STAR, classes: int = 5, min_depth: float = 0.0,
                        tol: float = 1e-8) -> SeedCheck:
    """Seed figure 4.3: "for the widest valleys the von Meier (d* = 0.054 1/mm) penetration lies
    between INRETS at E = 5 and 10 N/mm2, for the narrowest between E = 1 and 2".

    The valleys and penetrations are those of :func:`roadtex.comparisons.valley_penetration` (valleys
    bounded by the von Meier contact points, penetration below the chord joining the two asperities).
    The valleys are split into ``classes`` classes of equal count by width; in each, the median von
    Meier penetration is compared with the median INRETS penetration at each E.

    Args:
        heights: profile heights (m); detrended by the caller; solved as one period.
        dx: sampling interval (m).
        youngs_moduli: E values (Pa), any order.
        mean_pressure: P (Pa).
        d_star: the von Meier limit (1/m); the seed's 54 1/m.
        classes: number of width classes (>= 2).
        min_depth: ignore valleys shallower than this (m).
        tol: the contact solver's tolerance.

    Returns:
        ``data``: the :func:`valley_penetration` table plus ``width_class`` (0 = narrowest).
        ``summary``: one row per width class: ``width_class``, ``valleys``, ``width_min``,
        ``width_median``, ``width_max``, ``depth_median`` (m), ``von_meier_median`` (m), one column
        ``inrets_median_<E in MPa>`` (m) per E, ``modulus_below`` and ``modulus_above`` (Pa: the
        adjacent E values whose INRETS medians bracket the von Meier median, stiffer rubber
        penetrating less; beyond the range, null on the open side: (10 MPa, null) means "stiffer
        than 10 MPa") and ``matched_modulus`` (Pa, log-log interpolation between them; null when
        not bracketed or a median is not positive).
        ``holds``: the narrowest class is bracketed by 1 and 2 MPa and the widest by 5 and 10 MPa.
    """
    if int(classes) < 2:
        raise InvalidInputError(f"classes must be at least 2, got {classes!r}")
    moduli = np.sort(np.atleast_1d(np.asarray(youngs_moduli, dtype=np.float64)))
    data = valley_penetration(heights, dx, youngs_moduli=tuple(moduli), mean_pressure=mean_pressure,
                              d_star=d_star, min_depth=min_depth, tol=tol)
    if data.height == 0:
        raise InvalidInputError("the profile has no valley under the von Meier envelope")
    first = data.filter(pl.col("youngs_modulus") == moduli[0]).sort("valley")
    order = np.argsort(first["width"].to_numpy(), kind="stable")
    width_class = np.empty(order.size, dtype=np.int64)
    width_class[order] = (np.arange(order.size) * int(classes)) // order.size
    data = data.join(pl.DataFrame({"valley": first["valley"], "width_class": width_class}), on="valley",
                     maintain_order="left")
    rows = []
    for k in range(int(classes)):
        members = data.filter(pl.col("width_class") == k)
        one = members.filter(pl.col("youngs_modulus") == moduli[0])
        vm = float(one["von_meier_penetration"].median())  # type: ignore[arg-type]
        medians = np.array([float(members.filter(pl.col("youngs_modulus") == m)["inrets_penetration"].median())
                            for m in moduli])  # type: ignore[arg-type]
        below, above, matched = _bracket(vm, moduli, medians)
        rows.append({"width_class": k, "valleys": one.height, "width_min": one["width"].min(),
                     "width_median": one["width"].median(), "width_max": one["width"].max(),
                     "depth_median": one["depth"].median(), "von_meier_median": vm,
                     **{_modulus_column(m): v for m, v in zip(moduli, medians)},
                     "modulus_below": below, "modulus_above": above, "matched_modulus": matched})
    summary = pl.DataFrame(rows, schema_overrides={"modulus_below": pl.Float64, "modulus_above": pl.Float64,
                                                   "matched_modulus": pl.Float64})
    narrow, wide = summary.row(0, named=True), summary.row(summary.height - 1, named=True)
    holds = ((narrow["modulus_below"], narrow["modulus_above"]) == (1e6, 2e6)
             and (wide["modulus_below"], wide["modulus_above"]) == (5e6, 1e7))
    return SeedCheck(data, summary, bool(holds),
                     "widest valleys: von Meier between INRETS at E = 5 and 10 MPa; narrowest: between 1 and 2")


def _modulus_column(modulus: float) -> str:
    return f"inrets_median_{modulus / 1e6:g}MPa"


def _bracket(value: float, moduli: np.ndarray, medians: np.ndarray) -> tuple[float | None, float | None,
                                                                                 float | None]:
    """The adjacent moduli (ascending) whose medians (falling with E) bracket ``value``; beyond the
    range, the end modulus on the near side and None on the open side."""
    for i in range(moduli.size - 1):
        hi, lo = medians[i], medians[i + 1]   # softer penetrates more
        if lo <= value <= hi:
            if lo > 0 and hi > lo:
                t = (np.log(hi) - np.log(value)) / (np.log(hi) - np.log(lo))
                matched = float(np.exp(np.log(moduli[i]) + t * (np.log(moduli[i + 1]) - np.log(moduli[i]))))
            else:
                matched = None
            return float(moduli[i]), float(moduli[i + 1]), matched
    if value > medians[0]:
        return None, float(moduli[0]), None        # penetrates more than the softest rubber
    return float(moduli[-1]), None, None           # less than the stiffest


# --------------------------------------------------------------------------------------------------
# Segments, solves, levels: shared by figures 4.4 and 4.6
# --------------------------------------------------------------------------------------------------

def _segments(heights: object, dx: float, segment_length: float, name: str) -> np.ndarray:
    """Consecutive segments of ``segment_length`` (m), each less the line through its ends (as
    :meth:`roadtex.Profile.segments` cuts them), so the periodic model and the periodic levels of
    the original see no step at the wrap."""
    z = as_float_array(heights, name, 1)
    points = int(round(segment_length / dx))
    count = z.size // points
    if points < 8 or count < 1:
        raise InvalidInputError(f"{name} ({z.size} points) holds no segment of {segment_length:g} m at dx {dx:g} m")
    segments, _ = remove_end_lines(z[:count * points].reshape(count, points))
    return segments


def _levels_long(values: np.ndarray, dx: float, kind: BandKind, reference: float | None, method: Method,
                 keys: dict[str, np.ndarray], name: str) -> pl.DataFrame:
    """Band levels (periodic) of each row, long format, keyed by ``keys`` (one value per row)."""
    if reference is None:
        result = band_levels(values, dx, kind=kind, periodic=True, method=method)
    else:
        result = band_levels(values, dx, kind=kind, periodic=True, method=method, reference=reference)
    reported = result.bands["reported"].to_numpy()
    frame = result.to_frame().filter(pl.Series(np.tile(reported, values.shape[0])))
    extra = [pl.Series(k, v[frame["signal"].to_numpy()]) for k, v in keys.items()]
    return frame.with_columns(*extra).select(*keys, "band", "label", "centre_wavelength",
                                             pl.col("level_db").alias(name))


# --------------------------------------------------------------------------------------------------
# Figure 4.4: the depth effect of porous asphalt
# --------------------------------------------------------------------------------------------------

def depth_effect(profiles: Mapping[str, np.ndarray | Sequence[float]], dx: float, *, porous: str, dense: str,
                 youngs_moduli: Sequence[float] = SEED_MODULI, mean_pressure: float = 2e5,
                 segment_length: float = 0.2, kind: BandKind = "third_octave", method: Method = "dft",
                 tol: float = 1e-8) -> SeedCheck:
    """Seed figure 4.4: envelopment removes the "depth effect" of porous asphalt across the band range.

    Each profile is cut into segments of ``segment_length`` (each less the line through its ends, so
    that the periodic levels of the original see no step at the wrap), every segment solved by
    the periodic model at every E; the texture levels of the segments (``periodic=True``) and of their
    envelopes are energy-averaged over the segments of each profile. The depth effect is the porous
    profile's level minus the dense one's, before (original) and after envelopment (at the same E).

    Args:
        profiles: name -> heights (m), all at ``dx``; must include ``porous`` and ``dense``.
        dx: sampling interval (m).
        porous, dense: the names of the porous and the dense (reference) profile.
        youngs_moduli, mean_pressure, tol: the contact model's E values (Pa), P (Pa) and tolerance.
        segment_length: segment length (m).
        kind, method: bands and band method (see :func:`roadtex.band_levels`).

    Returns:
        ``data``: one row per (profile, E, band): ``profile``, ``youngs_modulus``, ``band``, ``label``,
        ``centre_wavelength``, ``original_db``, ``enveloped_db`` (reported bands only).
        ``summary``: one row per (E, band): ``depth_effect_original_db`` and
        ``depth_effect_enveloped_db`` (porous minus dense), ``reduction_db`` (the first minus the
        second) and ``removed`` (the original depth effect exceeds 1 dB and the enveloped one does not).
        ``holds``: at every E, the depth effect is removed in at least 80 % of the bands where the
        original one exceeds 1 dB.
    """
    for name in (porous, dense):
        if name not in profiles:
            raise InvalidInputError(f"profiles has no entry {name!r}; it has {sorted(profiles)}")
    dx = positive(dx, "dx", "metres")
    moduli = np.atleast_1d(np.asarray(youngs_moduli, dtype=np.float64))
    frames = []
    for name, heights in profiles.items():
        segments = _segments(heights, dx, to_float(segment_length, "segment_length"), f"profiles[{name!r}]")
        batch = contact_many(segments, dx, moduli, mean_pressure, tol=tol)
        original = _mean_levels(segments, dx, kind, method)
        for k, modulus in enumerate(moduli):
            enveloped = _mean_levels(batch.envelope[:, k], dx, kind, method)
            frames.append(original.join(enveloped, on=["band", "label", "centre_wavelength"], suffix="_env")
                          .select(pl.lit(name).alias("profile"), pl.lit(float(modulus)).alias("youngs_modulus"),
                                  "band", "label", "centre_wavelength", pl.col("level_db").alias("original_db"),
                                  pl.col("level_db_env").alias("enveloped_db")))
    data = pl.concat(frames)
    keys = ["youngs_modulus", "band", "label", "centre_wavelength"]
    p = data.filter(pl.col("profile") == porous).drop("profile")
    d = data.filter(pl.col("profile") == dense).drop("profile")
    summary = (p.join(d, on=keys, suffix="_dense")
               .select(*keys, (pl.col("original_db") - pl.col("original_db_dense")).alias("depth_effect_original_db"),
                       (pl.col("enveloped_db") - pl.col("enveloped_db_dense")).alias("depth_effect_enveloped_db"))
               .with_columns((pl.col("depth_effect_original_db") - pl.col("depth_effect_enveloped_db"))
                             .alias("reduction_db"),
                             ((pl.col("depth_effect_original_db") > 1.0) & (pl.col("depth_effect_enveloped_db") <= 1.0))
                             .alias("removed"))
               .sort("youngs_modulus", "band"))
    holds = True
    for modulus in moduli:
        rows = summary.filter((pl.col("youngs_modulus") == modulus) & (pl.col("depth_effect_original_db") > 1.0))
        if rows.height and float(rows["removed"].mean()) < 0.8:  # type: ignore[arg-type]
            holds = False
    return SeedCheck(data, summary, holds, "envelopment removes porous asphalt's depth effect across the bands")


def _mean_levels(values: np.ndarray, dx: float, kind: BandKind, method: Method) -> pl.DataFrame:
    """Energy mean over rows of the periodic band levels (reported bands only)."""
    result = band_levels(values, dx, kind=kind, periodic=True, method=method)
    with np.errstate(divide="ignore", invalid="ignore"):
        level = 10 * np.log10(np.mean(result.mean_square, axis=0) / result.reference**2)
    return result.bands.select("band", "label", "centre_wavelength", "reported").with_columns(
        pl.Series("level_db", level)).filter(pl.col("reported")).drop("reported")


# --------------------------------------------------------------------------------------------------
# Figure 4.6: pressure against enveloped texture, per band and E
# --------------------------------------------------------------------------------------------------

def pressure_texture_fits(profiles: Mapping[str, np.ndarray | Sequence[float]] | np.ndarray, dx: float, *,
                          youngs_moduli: Sequence[float] = SEED_MODULI, mean_pressure: float = 2e5,
                          segment_length: float = 0.2, kind: BandKind = "octave", method: Method = "dft",
                          min_r2: float = 0.5, tol: float = 1e-8) -> SeedCheck:
    """Seed figure 4.6: for each E, a linear relation between the pressure level and the enveloped
    texture level per octave band, across segments.

    Each profile is cut into segments (each less the line through its ends) and solved at every E;
    per segment, E and band the enveloped texture level (dB re 1 um) and the pressure level (dB re
    1 Pa) are computed (``periodic=True``), and a least-squares line pressure = slope * texture +
    intercept is fitted per (band, E) over all segments.

    Args:
        profiles: name -> heights (m), or one 2-D array whose rows are the segments already cut.
        dx: sampling interval (m).
        youngs_moduli, mean_pressure, tol: E values (Pa), P (Pa), solver tolerance.
        segment_length: segment length (m), when ``profiles`` is a mapping.
        kind, method: bands and band method.
        min_r2: the r^2 a fit needs for the relation to count as linear.

    Returns:
        ``data``: one row per (segment, E, band): ``profile``, ``segment``, ``youngs_modulus``,
        ``band``, ``label``, ``centre_wavelength``, ``texture_level`` and ``pressure_level`` (dB).
        ``summary``: one row per (band, E): ``slope`` (dB/dB), ``intercept`` (dB), ``r2``, ``n`` and
        ``scatter_db`` (rms residual about the line, dB).
        ``holds``: r^2 >= ``min_r2`` in at least 80 % of the (band, E) fits.
    """
    dx = positive(dx, "dx", "metres")
    if isinstance(profiles, Mapping):
        named = [(name, _segments(z, dx, to_float(segment_length, "segment_length"), f"profiles[{name!r}]"))
                 for name, z in profiles.items()]
    else:
        named = [("segments", as_float_array(profiles, "profiles", 2))]
    moduli = np.atleast_1d(np.asarray(youngs_moduli, dtype=np.float64))
    frames = []
    for name, segments in named:
        batch = contact_many(segments, dx, moduli, mean_pressure, tol=tol)
        for k, modulus in enumerate(moduli):
            keys = {"profile": np.full(segments.shape[0], name), "segment": np.arange(segments.shape[0]),
                    "youngs_modulus": np.full(segments.shape[0], float(modulus))}
            texture = _levels_long(batch.envelope[:, k], dx, kind, None, method, keys, "texture_level")
            pressure = _levels_long(batch.pressure[:, k], dx, kind, REFERENCE_PRESSURE, method, keys,
                                    "pressure_level")
            frames.append(texture.join(pressure, on=[*keys, "band", "label", "centre_wavelength"]))
    data = pl.concat(frames)
    fits = band_regressions(data, x="texture_level", y="pressure_level", by=("band", "youngs_modulus"))
    scatter = (data.join(fits.select("band", "youngs_modulus", "slope", "intercept"), on=["band", "youngs_modulus"])
               .filter(pl.col("texture_level").is_finite() & pl.col("pressure_level").is_finite())
               .group_by("band", "youngs_modulus")
               .agg(((pl.col("pressure_level") - pl.col("slope") * pl.col("texture_level") - pl.col("intercept")) ** 2)
                    .mean().sqrt().alias("scatter_db")))
    summary = fits.join(scatter, on=["band", "youngs_modulus"], how="left").sort("band", "youngs_modulus")
    usable = summary.filter(pl.col("r2").is_not_nan())
    holds = usable.height > 0 and float((usable["r2"] >= min_r2).mean()) >= 0.8  # type: ignore[arg-type]
    return SeedCheck(data, summary, bool(holds), "for each E, pressure level = slope * enveloped texture level "
                     "+ intercept per octave band")
