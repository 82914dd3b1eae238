"""The least-squares line of a profile, a segment or each row of a block, and the plane of a
surface's scattered readings: the one detrend that conditioning, segments, mean profile depth,
spectra, the plausibility check and the surfaces all use. Plain sums throughout, never a BLAS or
LAPACK call: those split their work over threads, and the thread count (all cores here, one in a
Dask worker) would change the last bits of every result."""

from __future__ import annotations

from typing import Literal

import numpy as np

from roadtex.errors import InvalidInputError


def line_fits(values: np.ndarray, positions: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares line through each row of ``values`` (the last axis).

    Args:
        values: (..., n) heights (m or any unit), NaN-free.
        positions: (n,) positions shared by every row, or an array of the shape of ``values``;
            None takes the sample index. Any unit: the slope is per that unit.

    Returns:
        (mean, slope, centred positions): the line of row r is ``mean[r] + slope[r] * centred``,
        with ``mean`` and ``slope`` of shape (..., 1), and ``centred`` the positions minus their
        mean. A row of one point, or whose positions are all equal, has slope 0.
    """
    z = np.asarray(values, dtype=np.float64)
    n = z.shape[-1]
    x = np.arange(n, dtype=np.float64) if positions is None else np.asarray(positions, dtype=np.float64)
    centred = x - x.mean(axis=-1, keepdims=True)
    mean = z.mean(axis=-1, keepdims=True)
    # Plain sums, never a matrix product: BLAS splits products over its threads, and the thread
    # count (all cores here, one in a Dask worker) would change the last bits of every result.
    spread_rows = np.sum(centred * centred, axis=-1, keepdims=True)
    covariance = np.sum(centred * (z - mean), axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = np.where(spread_rows > 0, covariance / spread_rows, 0.0)
    return mean, slope, centred


def remove_lines(values: np.ndarray, positions: np.ndarray | None = None,
                 kind: Literal["linear", "mean"] = "linear") -> tuple[np.ndarray, np.ndarray]:
    """Each row of ``values`` less its least-squares line (``"linear"``) or its mean (``"mean"``).

    Returns:
        (detrended, trend), both of the shape of ``values``: ``detrended + trend == values``
        to rounding.
    """
    if kind not in ("linear", "mean"):
        raise InvalidInputError(f"detrend must be 'linear' or 'mean', got {kind!r}")
    mean, slope, centred = line_fits(values, positions)
    trend = np.broadcast_to(mean, np.shape(values)) if kind == "mean" else mean + slope * centred
    trend = np.array(trend, dtype=np.float64)
    return np.asarray(values, dtype=np.float64) - trend, trend


def plane_fit(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> tuple[float, float, float, float, float]:
    """Least-squares plane z = a + b (x - xm) + c (y - ym) through scattered points (any units).

    Returns:
        (a, b, c, xm, ym), with xm and ym the means of x and y. Points all on one line along x
        (y constant) give c = 0.

    Raises:
        InvalidInputError: the points do not span a plane (all on one line not along x).
    """
    x, y, z = (np.asarray(v, dtype=np.float64).ravel() for v in (x, y, z))
    xm, ym = float(x.mean()), float(y.mean())
    # Centred on their means, the co-ordinates are orthogonal to the constant term: a is the mean
    # and (b, c) solve the 2 x 2 normal equations.
    xc, yc = x - xm, y - ym
    zm = float(z.mean())
    zc = z - zm
    sxx, syy, sxy = float(np.sum(xc * xc)), float(np.sum(yc * yc)), float(np.sum(xc * yc))
    sxz, syz = float(np.sum(xc * zc)), float(np.sum(yc * zc))
    if syy == 0.0 and sxx > 0.0:
        return zm, sxz / sxx, 0.0, xm, ym
    determinant = sxx * syy - sxy * sxy
    if not determinant > 1e-12 * sxx * syy:
        raise InvalidInputError("a plane needs readings spread along and across the road")
    return zm, (sxz * syy - syz * sxy) / determinant, (syz * sxx - sxz * sxy) / determinant, xm, ym
