"""Conditioning steps for surfaces: gross outlier and spike removal (:func:`clean`), drop-out
filling, spike removal, plane removal, resampling.

Each function returns a new surface and records one history line; :class:`Surface`'s methods of
the same names call them. The spike criterion is the one of the line profiles
(:func:`roadtex.profiles.conditioning.spike_mask`), with a 2-D median window; the gross outlier
criterion is the line profiles' own (:func:`roadtex.profiles.conditioning.outlier_mask`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from roadtex._checks import positive
from roadtex.errors import InvalidInputError
from roadtex.profiles.conditioning import (
    SPIKE_WINDOW,
    CleaningSummary,
    flag_outliers_and_spikes,
    format_number,
    removal_notes,
)
from roadtex.profiles.trend import plane_fit

if TYPE_CHECKING:
    from roadtex.surfaces.surface import Surface


def filled_heights(z: np.ndarray) -> np.ndarray:
    """``z`` (2-D, m) with NaN filled: linearly along each row (ends take the nearest valid
    height), then rows without any valid reading linearly across from the other rows."""
    out = z.copy()
    missing = np.isnan(out)
    if not missing.any():
        return out
    columns = np.arange(z.shape[1], dtype=np.float64)
    empty_rows = missing.all(axis=1)
    for row in np.flatnonzero(missing.any(axis=1) & ~empty_rows):
        gap = missing[row]
        out[row, gap] = np.interp(columns[gap], columns[~gap], out[row, ~gap])
    if empty_rows.any():
        if empty_rows.all():
            raise InvalidInputError("every reading is a drop-out: nothing to interpolate from")
        rows = np.arange(z.shape[0], dtype=np.float64)
        good = np.flatnonzero(~empty_rows)
        bad = np.flatnonzero(empty_rows)
        # linear across, column by column: weights of the nearest good rows below and above
        above = np.clip(np.searchsorted(good, bad), 1, good.size - 1) if good.size > 1 else np.zeros(bad.size, int)
        if good.size == 1:
            out[bad] = out[good[0]]
        else:
            lo, hi = good[above - 1], good[above]
            t = np.clip((rows[bad] - lo) / (hi - lo), 0.0, 1.0)[:, None]
            out[bad] = (1.0 - t) * out[lo] + t * out[hi]
    return out


def fill_dropouts(surface: Surface) -> Surface:
    """Fills drop-outs; documented at :meth:`Surface.fill_dropouts`."""
    missing = int(np.count_nonzero(np.isnan(surface.heights)))
    if missing == 0:
        return surface.derive(surface.heights.copy(), step="fill_dropouts(): no drop-outs")
    empty_rows = int(np.count_nonzero(np.isnan(surface.heights).all(axis=1)))
    filled = filled_heights(surface.heights)
    return surface.derive(filled, step=f"fill_dropouts(): {missing} readings interpolated linearly along rows"
                          f"{f', {empty_rows} empty rows across' if empty_rows else ''}")


def spike_window(dx: float, dy: float) -> np.ndarray:
    """The footprint of the spike criterion's median: an ellipse of SPIKE_WINDOW (m) radius in x and
    y, at least one neighbour each way (rows across, columns along)."""
    hx = max(1, int(round(SPIKE_WINDOW / dx)))
    hy = max(1, int(round(SPIKE_WINDOW / dy)))
    iy, ix = np.mgrid[-hy:hy + 1, -hx:hx + 1]
    return (iy / hy) ** 2 + (ix / hx) ** 2 <= 1.0 + 1e-12


def spike_mask(surface: Surface, alpha: float) -> np.ndarray:
    """Readings that are spikes (True): at least ``alpha`` x SPIKE_WINDOW (m) from the median of the
    readings within SPIKE_WINDOW of them on the surface (the elliptical window of
    :func:`spike_window`) and also from the median within SPIKE_WINDOW along their own row (the
    line profiles' criterion, :func:`roadtex.profiles.conditioning.spike_mask`). Requiring both
    keeps sharp corners of steep stone edges, which a 2-D window alone flags at fine sampling
    (most of the window lies on the other side of a right-angled corner), and never flags more on
    a row than the line criterion would. Drop-outs are filled for the medians only."""
    from scipy import ndimage  # scipy on first use: the command line starts without it
    alpha_f = positive(alpha, "alpha", "a slope, no unit")
    z = surface.heights
    valid = ~np.isnan(z)
    filled = filled_heights(z)
    threshold = alpha_f * SPIKE_WINDOW
    local = ndimage.median_filter(filled, footprint=spike_window(surface.dx, surface.dy), mode="nearest")
    mask = valid & (np.abs(z - local) >= threshold)
    if mask.any():
        half = max(1, int(round(SPIKE_WINDOW / surface.dx)))
        along = ndimage.median_filter(filled, size=(1, 2 * half + 1), mode="nearest")
        mask &= np.abs(z - along) >= threshold
    return mask


def remove_spikes(surface: Surface, alpha: float = 3.0) -> Surface:
    """Flags spikes as drop-outs; documented at :meth:`Surface.remove_spikes`."""
    spikes = spike_mask(surface, alpha)
    z = np.where(spikes, np.nan, surface.heights)
    step = (f"remove_spikes(alpha={format_number(float(alpha))}): {int(spikes.sum())} readings at least "
            f"{format_number(float(alpha) * SPIKE_WINDOW * 1e3)} mm from the median within "
            f"{format_number(SPIKE_WINDOW * 1e3)} mm flagged as drop-outs")
    return surface.derive(z, step=step)


def clean(surface: Surface, spike_alpha: float | None = 3.0) -> tuple[Surface, CleaningSummary]:
    """Flags gross outliers and then spikes as drop-outs (NaN), as the line profiles'
    :func:`roadtex.profiles.conditioning.clean` does (no reference plates: surfaces have none).

    Returns the cleaned surface (drop-outs not yet filled) and what was removed (shares 0..1 of
    the readings), with a note, as the line runs record it, for each share beyond the line
    profiles' thresholds (:data:`~roadtex.profiles.conditioning.WARN_SPIKE_FRACTION` for spikes
    and outliers together, :data:`~roadtex.profiles.conditioning.WARN_DROPOUT_FRACTION` for the
    file's drop-outs); nothing is warned here, the notes are returned.
    """
    cleaned, shares = flag_outliers_and_spikes(surface, spike_alpha, spike_mask, "within ")
    summary = CleaningSummary(raw_length=surface.length, trimmed_length=0.0, plates="none", **shares, warnings=())
    return cleaned, dataclasses.replace(summary, warnings=removal_notes(summary))


def remove_plane(surface: Surface) -> Surface:
    """Removes the least-squares plane of the valid readings; documented at :meth:`Surface.remove_plane`."""
    z = surface.heights
    valid = ~np.isnan(z)
    iy, ix = np.nonzero(valid)
    x = surface.x0 + surface.dx * ix
    y = surface.y0 + surface.dy * iy
    try:
        a, b, c, xm, ym = plane_fit(x, y, z[valid])
    except InvalidInputError:
        raise InvalidInputError("remove_plane needs valid readings spread along and across the road") from None
    xs = surface.x[None, :] - xm
    ys = surface.y[:, None] - ym
    plane = a + b * xs + c * ys
    offset = a - b * (xm - 0.0) - c * (ym - 0.0)
    step = (f"remove_plane(): removed slopes {format_number(b)} along and {format_number(c)} across "
            f"and offset {format_number(offset)} m at x = y = 0")
    return surface.derive(z - plane, step=step)


def bins(n: int, old: float, new: float) -> tuple[np.ndarray, int]:
    """Index of the new interval each of ``n`` old cells (spacing ``old``) falls into, and the count
    of new intervals of spacing ``new`` that tile the old extent from its edge."""
    n_bins = max(1, int(math.ceil(n * old / new - 1e-9)))
    index = np.floor((np.arange(n) + 0.5) * (old / new) + 1e-9).astype(np.int64)
    return np.clip(index, 0, n_bins - 1), n_bins


def resample(surface: Surface, dx: float, dy: float) -> Surface:
    """Resamples by interval averaging in both directions; documented at :meth:`Surface.resample`."""
    new_dx, new_dy = positive(dx, "dx"), positive(dy, "dy")
    for name, new, own in (("dx", new_dx, surface.dx), ("dy", new_dy, surface.dy)):
        if new < own * (1 - 1e-9):
            # averaging onto a finer grid leaves most cells without a reading (all NaN but one in
            # (own / new)^2), and the next step fails on rows of drop-outs
            raise InvalidInputError(
                f"resample: {name} {new:.6g} m is finer than the surface's own spacing {own:.6g} m; resampling "
                "averages readings, so it only makes a surface coarser (a finer grid would be all drop-outs "
                f"but one cell in {own / new:.3g}): give {name} >= {own:.6g} m")
    z = surface.heights
    bx, nbx = bins(z.shape[1], surface.dx, new_dx)
    by, nby = bins(z.shape[0], surface.dy, new_dy)
    valid = ~np.isnan(z)
    cell = (by[:, None] * nbx + bx[None, :])[valid]
    sums = np.bincount(cell, weights=z[valid], minlength=nbx * nby)
    counts = np.bincount(cell, minlength=nbx * nby)
    with np.errstate(invalid="ignore", divide="ignore"):
        new = (sums / counts).reshape(nby, nbx)
    empty = int(np.count_nonzero(counts == 0))
    if empty == counts.size:
        raise InvalidInputError("resampling leaves no valid reading")
    x0 = surface.x0 - 0.5 * surface.dx + 0.5 * new_dx
    y0 = surface.y0 - 0.5 * surface.dy + 0.5 * new_dy
    step = (f"resample(dx={format_number(new_dx)} m, dy={format_number(new_dy)} m): {z.shape[0]} x {z.shape[1]} -> "
            f"{nby} x {nbx} readings by interval averaging, {empty} empty cells")
    return surface.derive(new, dx=new_dx, dy=new_dy, x0=x0, y0=y0, step=step)
