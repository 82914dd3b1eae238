"""Band levels in use: wavelength to frequency at a vehicle speed, level differences between two
spectra, and pressure-against-texture regressions per band (the seed's figure 4.6)."""

from __future__ import annotations

from typing import Sequence

import numpy as np
import polars as pl

from roadtex._checks import positive
from roadtex.errors import InvalidInputError
from roadtex.spectra.bands import BAND_COLUMNS, FREQUENCY_COLUMNS

# --------------------------------------------------------------------------------------------------
# Time frequency, differences, regressions
# --------------------------------------------------------------------------------------------------

def time_frequency(wavelength_m: float | np.ndarray, speed_kmh: float) -> float | np.ndarray:
    """Temporal frequency f = V / wavelength (Hz) excited by texture of that wavelength (m) at V (km/h).

    The conversion Clapp used: a vehicle at V km/h passes V / 3.6 metres of road per second, so a
    wavelength of 8 mm at 80 km/h excites 22.2 / 0.008 = 2,778 Hz.
    """
    speed = positive(speed_kmh, "speed_kmh", "km/h")
    wavelength = np.asarray(wavelength_m, dtype=np.float64)
    if not np.all(np.isfinite(wavelength) & (wavelength > 0.0)):
        raise InvalidInputError("wavelength_m must be positive finite wavelengths in metres")
    frequency = speed / 3.6 / wavelength
    return float(frequency) if frequency.ndim == 0 else frequency


def with_time_frequency(table: pl.DataFrame, speed_kmh: float) -> pl.DataFrame:
    """Adds the time-frequency band (Hz) at vehicle speed ``speed_kmh`` to a band table.

    Adds ``speed_kmh``, ``centre_frequency``, ``lower_frequency`` (from ``upper_wavelength``) and
    ``upper_frequency`` (from ``lower_wavelength``), all f = V / wavelength.
    """
    speed = positive(speed_kmh, "speed_kmh", "km/h")
    missing = {"centre_wavelength", "lower_wavelength", "upper_wavelength"} - set(table.columns)
    if missing:
        raise InvalidInputError(f"table lacks the band columns {sorted(missing)}; pass a band_table or levels table")
    metres_per_second = speed / 3.6
    return table.with_columns(
        pl.lit(speed).alias("speed_kmh"),
        (metres_per_second / pl.col("centre_wavelength")).alias("centre_frequency"),
        (metres_per_second / pl.col("upper_wavelength")).alias("lower_frequency"),
        (metres_per_second / pl.col("lower_wavelength")).alias("upper_frequency"),
    )


_NOT_KEYS = set(BAND_COLUMNS) | set(FREQUENCY_COLUMNS) | {"mean_square", "level_db"}


def check_same_bands(enveloped: pl.DataFrame, original: pl.DataFrame) -> None:
    """Refuses tables whose bands of one number are not the same bands: an octave table against a
    third-octave one (other band edges), or signals of other lengths or sampling (other DFT lines
    in the band). Only the band columns both tables carry are compared."""
    for column, what in (("lower_wavelength", "band edges (octave against third-octave bands?)"),
                         ("upper_wavelength", "band edges (octave against third-octave bands?)"),
                         ("lines", "numbers of DFT lines (signals of other lengths or sampling intervals?)")):
        if column not in enveloped.columns or column not in original.columns:
            continue
        pairs = (enveloped.select("band", pl.col(column).alias("a")).unique()
                 .join(original.select("band", pl.col(column).alias("b")).unique(), on="band"))
        differ = pairs.filter((pl.col("a") != pl.col("b")) & ~((pl.col("a") - pl.col("b")).abs()
                                                              <= 1e-9 * pl.col("a").abs()))
        if differ.height:
            band = differ.row(0, named=True)
            raise InvalidInputError(f"enveloped and original have other {what}: band {band['band']} has "
                                    f"{column} {band['a']!r} in enveloped and {band['b']!r} in original; compare "
                                    "levels of the same band kind, computed on signals of the same length and dx")


def level_differences(enveloped: pl.DataFrame, original: pl.DataFrame, *, level: str = "level_db",
                      on: Sequence[str] | None = None) -> pl.DataFrame:
    """Enveloped-minus-original level per band (the seed's figure 4.4, bottom).

    Analyse both profiles the same way. For segments solved by the periodic contact model, that means
    ``periodic=True`` for the original too: the model sees the segment as one period, and its envelope
    is exactly periodic. Mixing a windowed original with a periodic envelope shifts the long bands by
    window bias (a few dB at 12 wavelengths per segment), which is not envelopment. Cut the segments
    seamless (:meth:`roadtex.Profile.segments` does by default: each less the line through its ends):
    a periodic original whose ends differ has a step at every wrap, whose power (falling as 1/k^2)
    the envelope bridges, so the difference would carry it. On synthetic porous asphalt in 0.5 m
    least-squares segments at 0.1 mm that step read -1 to -6 dB from 1 to 0.4 mm as envelopment.

    Args:
        enveloped: levels of enveloped profiles; may carry extra keys such as ``youngs_modulus``.
        original: levels of the original profiles, one row per key.
        level: the level column in both tables.
        on: key columns; by default ``band`` plus every other column both tables share, except band
            metadata, frequency columns, ``mean_square`` and the level (e.g. ``site``, ``segment``).

    Returns:
        ``enveloped`` with ``original_level_db`` and ``level_difference_db`` (dB) added; null where the
        original has no row for the key.
    """
    for name, table in (("enveloped", enveloped), ("original", original)):
        if level not in table.columns or "band" not in table.columns:
            raise InvalidInputError(f"{name} must have the columns 'band' and {level!r}, has {table.columns}")
    check_same_bands(enveloped, original)
    if on is None:
        keys = ["band"] + [c for c in enveloped.columns
                           if c in original.columns and c not in _NOT_KEYS and c != level]
    else:
        keys = list(on)
        missing = [c for c in keys if c not in enveloped.columns or c not in original.columns]
        if missing:
            raise InvalidInputError(f"key columns {missing} are not in both tables")
    reference = original.select(*keys, pl.col(level).alias("original_level_db"))
    if reference.select(keys).is_duplicated().any():
        raise InvalidInputError(f"original has more than one row for some ({', '.join(keys)}); "
                         "pass on= with the columns that identify a profile")
    joined = enveloped.join(reference, on=keys, how="left", maintain_order="left")
    return joined.with_columns((pl.col(level) - pl.col("original_level_db")).alias("level_difference_db"))


def band_regressions(table: pl.DataFrame, *, x: str = "texture_level", y: str = "pressure_level",
                     by: Sequence[str] = ("band", "youngs_modulus")) -> pl.DataFrame:
    """Least-squares line y = slope x + intercept per group (the seed's figure 4.6: per band and E).

    Rows with a non-finite x or y (NaN, -inf levels) are left out of the fit.

    Returns:
        One row per group, sorted by ``by``: the ``by`` columns, ``label`` and ``centre_wavelength`` when
        present in ``table``, ``slope`` (dB/dB), ``intercept`` (dB), ``r2`` and ``n`` (rows used). slope
        and intercept are NaN with fewer than 2 distinct x; r2 is NaN when y is constant.
    """
    by = [by] if isinstance(by, str) else list(by)
    missing = [c for c in (*by, x, y) if c not in table.columns]
    if missing:
        raise InvalidInputError(f"table lacks the columns {missing}; it has {table.columns}")
    ok = pl.col(x).cast(pl.Float64).is_finite() & pl.col(y).cast(pl.Float64).is_finite()
    xs, ys = pl.col(x).cast(pl.Float64).filter(ok), pl.col(y).cast(pl.Float64).filter(ok)
    carried = [pl.col(c).first() for c in ("label", "centre_wavelength") if c in table.columns and c not in by]
    grouped = table.group_by(by, maintain_order=True).agg(
        *carried,
        ok.sum().cast(pl.Int64).alias("n"),
        xs.mean().alias("_mx"), ys.mean().alias("_my"),
        ((xs - xs.mean()) ** 2).sum().alias("_sxx"),
        ((ys - ys.mean()) ** 2).sum().alias("_syy"),
        ((xs - xs.mean()) * (ys - ys.mean())).sum().alias("_sxy"),
    )
    fit = (pl.col("n") >= 2) & (pl.col("_sxx") > 0.0)
    slope = pl.when(fit).then(pl.col("_sxy") / pl.col("_sxx")).otherwise(float("nan"))
    return (grouped
            .with_columns(slope.alias("slope"))
            .with_columns(
                (pl.col("_my") - pl.col("slope") * pl.col("_mx")).alias("intercept"),
                pl.when(fit & (pl.col("_syy") > 0.0))
                .then(pl.col("_sxy") ** 2 / (pl.col("_sxx") * pl.col("_syy"))).otherwise(float("nan")).alias("r2"))
            .select(*by, *[c for c in ("label", "centre_wavelength") if c in table.columns and c not in by],
                    "slope", "intercept", "r2", "n")
            .sort(by))
