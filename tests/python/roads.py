"""The roads the model grid joins readings by, written independently of roadtex.models.grid.

The job's default road is the monotone cubic (pchip, since 0.5.0); the tests that check a job's or a
pilot's levels against the same readings solved much finer build that finer road here, without
:func:`roadtex.models.grid.refine_periodic`: scipy's :class:`~scipy.interpolate.PchipInterpolator`
through the readings repeated over three periods (the grid module pads three readings each side), and
numpy's linear interpolation for the linear road. ``tests/python`` is on ``sys.path`` (conftest.py).
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import PchipInterpolator


def linear_road(heights: np.ndarray, refine: int) -> np.ndarray:
    """(rows, N k): periodic rows of N readings joined by straight lines, every 1 / refine of a step."""
    rows = np.atleast_2d(heights)
    n = rows.shape[-1]
    fine = np.arange(n * refine) / refine
    return np.array([np.interp(fine, np.arange(n + 1), np.append(row, row[0])) for row in rows])


def pchip_road(heights: np.ndarray, refine: int) -> np.ndarray:
    """(rows, N k): periodic rows of N readings joined by monotone cubics (Fritsch-Carlson)."""
    rows = np.atleast_2d(heights)
    n = rows.shape[-1]
    positions = np.arange(-n, 2 * n, dtype=np.float64)
    curve = PchipInterpolator(positions, np.concatenate([rows, rows, rows], axis=-1), axis=-1)
    return curve(np.arange(n * refine) / refine)


def job_road(heights: np.ndarray, refine: int) -> np.ndarray:
    """The job's default road (pchip) through periodic rows of readings, ``refine`` times finer."""
    return pchip_road(heights, refine)


def road_at(heights: np.ndarray, points: int, interpolant: str = "pchip") -> np.ndarray:
    """(rows, points): the road through periodic rows of N readings (``"pchip"`` or ``"linear"``)
    sampled at ``points`` equal intervals per period (any count, not only a multiple of N)."""
    rows = np.atleast_2d(heights)
    n = rows.shape[-1]
    where = np.arange(points) * n / points
    if interpolant == "linear":
        return np.array([np.interp(where, np.arange(n + 1), np.append(row, row[0])) for row in rows])
    curve = PchipInterpolator(np.arange(-n, 2 * n, dtype=np.float64), np.concatenate([rows, rows, rows], axis=-1),
                              axis=-1)
    return curve(where)
