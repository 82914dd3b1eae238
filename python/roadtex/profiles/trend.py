"""The least-squares line of a profile, a segment or each row of a block: the one detrend that
conditioning, segments, mean profile depth, spectra and the plausibility check all use."""

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
