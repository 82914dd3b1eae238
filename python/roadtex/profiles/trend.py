"""The least-squares line of a profile, a segment or each row of a block, and the plane of a
surface's scattered readings: the one detrend that conditioning, mean profile depth, spectra, the
plausibility check and the surfaces all use; and the line through a segment's ends
(:func:`remove_end_lines`), which segments for the periodic contact model take by default. Plain sums throughout, never a BLAS or
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


def remove_end_lines(values: np.ndarray, positions: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Each row of ``values`` less the line through its first and last sample, offset to mean zero.

    A segment repeated end to start (the periodic contact model, periodic band levels) meets
    itself at its ends. After the least-squares line the ends still differ by the texture there
    (2.7 mm rms on porous asphalt and CAPTIF in 0.5 m segments), and that step at every wrap adds
    power falling as 1/k^2 to every band, the short ones most: on synthetic porous asphalt +0.2 to
    +0.7 dB from 2.5 to 1.25 mm at 0.5 mm sampling and +4.8 dB at 0.4 mm at 0.1 mm (means over 8
    profiles, against the whole record's Hann-windowed levels). Less this line the first and last
    samples are equal, so the periodic extension has no step, and those bands agree with the Hann
    levels within 0.1 dB. The end samples themselves are the estimate: noise on them only tilts the
    segment by a line of that size, far below the texture. The sample extrapolated past the end
    gives the same within 0.02 dB; means over 0.5 or 2 mm at each end leave the texture's own
    fluctuation there as a step (rms error in the four shortest bands at 0.1 mm 0.12 and 1.35 dB,
    against 0.06); ``benches/seamless_segments.py``.

    Args:
        values: (..., n) heights (m or any unit), NaN-free, n >= 2.
        positions: (n,) positions shared by every row; None takes the sample index. A row whose
            first and last positions are equal gets slope 0.

    Returns:
        (detrended, trend), both of the shape of ``values``: ``detrended + trend == values`` to
        rounding, each row of ``detrended`` has mean zero and equal first and last samples (to
        rounding).
    """
    z = np.asarray(values, dtype=np.float64)
    n = z.shape[-1]
    x = np.arange(n, dtype=np.float64) if positions is None else np.asarray(positions, dtype=np.float64)
    span = x[..., -1:] - x[..., :1]
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = np.where(span != 0, (z[..., -1:] - z[..., :1]) / span, 0.0)
    centred = x - x.mean(axis=-1, keepdims=True)
    trend = np.array(z.mean(axis=-1, keepdims=True) + slope * centred, dtype=np.float64)
    trend = np.broadcast_to(trend, z.shape).copy()
    return z - trend, trend


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
