"""The seed's model comparisons as tidy tables, ready to plot: valleys and how far each model's rubber
penetrates them (figure 4.3), von Meier envelopes at several d* (figure 2.1), and the edge effect of
a finite sample (figure 3.1).

Every function returns a polars DataFrame in SI units (m, Pa, 1/m), one observation per row, with
the units in the docstring. A matplotlib script can plot a column against another directly, for
instance, for figure 4.3, ``inrets_penetration`` against ``von_meier_penetration`` with one colour
per ``youngs_modulus``.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
import polars as pl

from roadtex._checks import as_float_array, to_float
from roadtex.errors import InvalidInputError
from roadtex.models.contact import contact, contact_many
from roadtex.models.envelopes import von_meier
from roadtex.models.reference import flat_punch_element_pressure

SEED_D_STAR = 54.0
"""The seed's von Meier curvature limit, 0.054 1/mm, in 1/m."""
#: The curvature limits d* (1/m) of the bulk job's von Meier table (the report's figure 2.1).
EXAMPLE_D_STARS = (13.5, 27.0, 54.0, 108.0)
#: Valleys shallower than this (m) are left out of the bulk job's penetration table (figure 4.3).
EXAMPLE_MIN_DEPTH = 2e-5

VALLEY_COLUMNS = {
    "valley": pl.Int64, "start": pl.Int64, "end": pl.Int64, "x_start": pl.Float64, "x_end": pl.Float64,
    "x_deepest": pl.Float64, "width": pl.Float64, "depth": pl.Float64,
}


def valleys(heights: np.ndarray | Sequence[float], dx: float, *, d_star: float = SEED_D_STAR,
            min_depth: float = 0.0) -> pl.DataFrame:
    """The valleys of a profile, as the von Meier envelope at ``d_star`` sees them.

    A valley is a maximal run of points where the von Meier envelope stays above the profile; it is
    bounded by two asperities, the contact points ``start`` and ``end`` on either side (the envelope
    touches the profile at both ends of the sample, so every valley has both). One valley set per
    profile, whatever the model: it is the common ground on which the models' penetrations are
    compared.

    Depth is measured below the straight line joining the two bounding asperities (not below the
    envelope, whose bridging differs from model to model): depth = max over the valley of
    line - heights.

    Args:
        heights: profile heights (m), at least 3 points.
        dx: sampling interval (m).
        d_star: the von Meier curvature limit (1/m) that picks out the valleys; the seed's 54 1/m.
        min_depth: drop valleys shallower than this (m).

    Returns:
        One row per valley, left to right: ``valley`` (0, 1, ...), ``start`` and ``end`` (indices of
        the bounding asperities), ``x_start``, ``x_end``, ``x_deepest`` (m, positions i dx; the
        deepest point below the line), ``width`` (m, (end - start) dx) and ``depth`` (m).
    """
    z = as_float_array(heights, "heights", 1)
    dx_f = to_float(dx, "dx")
    envelope = von_meier(z, dx_f, d_star)
    rows = []
    for start, end in _bridged_runs(envelope > z):
        line = _line(z, start, end)
        below = line - z[start:end + 1]
        deepest = int(np.argmax(below))
        depth = float(below[deepest])
        if depth < min_depth:
            continue
        rows.append((start, end, start * dx_f, end * dx_f, (start + deepest) * dx_f, (end - start) * dx_f, depth))
    frame = pl.DataFrame(rows, schema=list(VALLEY_COLUMNS)[1:], orient="row")
    frame = frame.with_row_index("valley").with_columns(pl.col("valley").cast(pl.Int64))
    return frame.cast(VALLEY_COLUMNS)  # type: ignore[arg-type]


def penetration(heights: np.ndarray, envelope: np.ndarray, valley_table: pl.DataFrame) -> np.ndarray:
    """How far a rubber surface ``envelope`` (m) reaches into each valley of ``valley_table``
    (from :func:`valleys` on the same ``heights``): max over the valley of line - envelope, the line
    joining the valley's bounding asperities. Between 0 and the valley's depth when the rubber rests
    on both asperities; equal to the depth when it touches the bottom; negative when the rubber
    hangs above the asperities themselves (a stiff rubber that does not reach them)."""
    z = as_float_array(heights, "heights", 1)
    e = as_float_array(envelope, "envelope", 1)
    if e.shape != z.shape:
        raise InvalidInputError(f"envelope has {e.size} points, heights {z.size}: they must match")
    starts, ends = valley_table["start"].to_numpy(), valley_table["end"].to_numpy()
    return np.array([float(np.max(_line(z, a, b) - e[a:b + 1])) for a, b in zip(starts, ends)], dtype=np.float64)


def valley_penetration(heights: np.ndarray | Sequence[float], dx: float, *,
                       youngs_moduli: Sequence[float] = (1e6, 2.5e6, 5e6, 1e7), mean_pressure: float = 2e5,
                       d_star: float = SEED_D_STAR, poisson: float = 0.5, min_depth: float = 0.0,
                       tol: float = 1e-10) -> pl.DataFrame:
    """Seed figure 4.3: how far the rubber penetrates each valley, von Meier against INRETS.

    The valleys are those of :func:`valleys` (bounded by the von Meier contact points at
    ``d_star``); the penetration is that of :func:`penetration`, for the von Meier envelope at
    ``d_star`` and for the periodic INRETS model (:func:`roadtex.contact`) at each modulus. The
    INRETS model takes the profile as periodic; the von Meier envelope does not (it touches both
    ends).

    Args:
        heights: profile heights (m), N >= 8.
        dx: sampling interval (m).
        youngs_moduli: E values (Pa) for the INRETS model.
        mean_pressure: P (Pa).
        d_star: von Meier curvature limit (1/m), the seed's 54 1/m.
        poisson, tol: as for :func:`roadtex.contact`.
        min_depth: drop valleys shallower than this (m).

    Returns:
        One row per (valley, modulus): the columns of :func:`valleys`, then ``d_star`` (1/m),
        ``von_meier_penetration`` (m), ``youngs_modulus`` (Pa), ``mean_pressure`` (Pa),
        ``inrets_penetration`` (m, signed: negative where the rubber hangs above the line joining
        the asperities), and the share of each valley's depth that the rubber fills,
        ``von_meier_ratio`` and ``inrets_ratio`` (penetration clipped to [0, depth], over depth:
        0 where the rubber does not get below that line, 1 where it touches the bottom).
    """
    z = as_float_array(heights, "heights", 1)
    dx_f = to_float(dx, "dx")
    moduli = np.atleast_1d(np.asarray(youngs_moduli, dtype=np.float64))
    batch = contact_many(z[None, :], dx_f, moduli, mean_pressure, poisson=poisson, tol=tol)
    envelopes = {float(modulus): batch.envelope[0, k] for k, modulus in enumerate(moduli)}
    return penetration_table(z, dx_f, envelopes, mean_pressure=mean_pressure, d_star=d_star, min_depth=min_depth)


def penetration_table(heights: np.ndarray | Sequence[float], dx: float, envelopes: Mapping[float, np.ndarray], *,
                      mean_pressure: float, d_star: float = SEED_D_STAR, min_depth: float = 0.0) -> pl.DataFrame:
    """:func:`valley_penetration` for envelopes already solved (m, keyed by E in Pa, at ``mean_pressure``
    Pa): the same table, without solving (the report draws it from the bulk job's own solves)."""
    z = as_float_array(heights, "heights", 1)
    dx_f = to_float(dx, "dx")
    table = valleys(z, dx_f, d_star=d_star, min_depth=min_depth)
    vm = penetration(z, von_meier(z, dx_f, d_star), table)
    depth = table["depth"].to_numpy()
    frames = []
    for modulus, envelope in envelopes.items():
        inrets = penetration(z, envelope, table)
        frames.append(table.with_columns(
            pl.lit(float(d_star)).alias("d_star"),
            pl.Series("von_meier_penetration", vm),
            pl.lit(float(modulus)).alias("youngs_modulus"),
            pl.lit(float(mean_pressure)).alias("mean_pressure"),
            pl.Series("inrets_penetration", inrets),
            pl.Series("von_meier_ratio", _ratio(vm, depth)),
            pl.Series("inrets_ratio", _ratio(inrets, depth)),
        ))
    return pl.concat(frames)


def von_meier_envelopes(heights: np.ndarray | Sequence[float], dx: float, *,
                        d_stars: Sequence[float] = (10.0, SEED_D_STAR, 200.0, 1000.0)) -> pl.DataFrame:
    """Seed figure 2.1: von Meier envelopes of one profile at several curvature limits d*.

    Returns:
        One row per (d*, point): ``d_star`` (1/m), ``index``, ``x`` (m, i dx), ``height`` (m),
        ``envelope`` (m) and ``depth`` (m, envelope - height). The larger d*, the lower the
        envelope: the rubber sags deeper into the valleys.
    """
    z = as_float_array(heights, "heights", 1)
    dx_f = to_float(dx, "dx")
    index = np.arange(z.size)
    frames = []
    for d_star in d_stars:
        e = von_meier(z, dx_f, d_star)
        frames.append(pl.DataFrame({
            "d_star": np.full(z.size, float(d_star)), "index": index, "x": index * dx_f, "height": z,
            "envelope": e, "depth": e - z,
        }))
    return pl.concat(frames)


def example_comparisons(heights: np.ndarray, dx: float, envelopes: Mapping[float, np.ndarray], *,
                        mean_pressure: float) -> tuple[pl.DataFrame, pl.DataFrame]:
    """The seed's model comparisons for one segment solved by the bulk job (heights and the
    INRETS ``envelopes``, m, keyed by E in Pa, at ``mean_pressure`` Pa; sampling ``dx``, m): the
    von Meier envelopes at :data:`EXAMPLE_D_STARS` (:func:`von_meier_envelopes`) and the valley
    penetration table at :data:`SEED_D_STAR` without valleys shallower than
    :data:`EXAMPLE_MIN_DEPTH` (:func:`penetration_table`), the tables the report draws."""
    return (von_meier_envelopes(heights, dx, d_stars=EXAMPLE_D_STARS),
            penetration_table(heights, dx, envelopes, mean_pressure=mean_pressure, min_depth=EXAMPLE_MIN_DEPTH))


def edge_effect(*, points: int = 1024, length: float = 0.1, youngs_modulus: float = 2.5e6,
                mean_pressure: float = 2e5, poisson: float = 0.5, tol: float = 1e-12) -> pl.DataFrame:
    """Seed figure 3.1: the edge effect of a finite sample, on a flat profile.

    The same flat profile of ``points`` elements over ``length`` (m) is pressed with the finite
    model (``periodic=False``: pressure rising at both ends, sagging to 2 P / pi in the middle, the
    rigid flat punch) and with the periodic INRETS model (uniform P); the exact flat punch,
    averaged per element, is given as a third model for reference.

    Returns:
        One row per (model, element): ``model`` ("finite", "periodic" or "flat punch (exact)"),
        ``index``, ``x`` (m, element centre (i + 1/2) dx), ``pressure`` (Pa) and
        ``pressure_ratio`` (p / P).
    """
    n = int(points)
    dx = to_float(length, "length") / n
    flat = np.zeros(n)
    x = (np.arange(n) + 0.5) * dx
    pressures = {
        "finite": contact(flat, dx, youngs_modulus, mean_pressure, poisson=poisson, periodic=False, tol=tol).pressure,
        "periodic": contact(flat, dx, youngs_modulus, mean_pressure, poisson=poisson, tol=tol).pressure,
        "flat punch (exact)": flat_punch_element_pressure(x, dx, n * dx, mean_pressure),
    }
    return pl.concat([
        pl.DataFrame({"model": [model] * n, "index": np.arange(n), "x": x, "pressure": p,
                      "pressure_ratio": p / mean_pressure})
        for model, p in pressures.items()
    ])


def _bridged_runs(above: np.ndarray) -> list[tuple[int, int]]:
    """(start, end) contact indices bounding each maximal run of True in ``above``."""
    padded = np.concatenate(([False], above, [False])).astype(np.int8)
    change = np.diff(padded)
    first, after = np.flatnonzero(change == 1), np.flatnonzero(change == -1)
    return [(int(a) - 1, int(b)) for a, b in zip(first, after)]


def _line(z: np.ndarray, a: int, b: int) -> np.ndarray:
    """The straight line from (a, z[a]) to (b, z[b]) at a..b inclusive."""
    t = np.arange(b - a + 1) / (b - a)
    return z[a] + t * (z[b] - z[a])


def _ratio(values: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """Penetration as a share of the depth, clipped to [0, 1]; NaN for a valley of zero depth."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(depth > 0, np.clip(values, 0.0, depth) / depth, np.nan)
