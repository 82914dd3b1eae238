"""The model's grid apart from the data's: the continuous road that a profile's samples describe,
put on a grid ``k`` times finer than the data for the contact model.

A profile's samples describe a continuous road; the contact model's element grid is a numerical
choice. The rubber rests on asperity tops that a 0.5 or 1 mm grid resolves with a few elements
each, so solving on the data's own grid errs by up to 3 dB on 1 mm profiles (the model-grid issue's
table: CAPTIF station 0 averaged to 1 mm, 3.1 dB at k = 1, 0.5 at k = 2, 0.1 at k = 4, 0.04 at
k = 8). The samples are therefore first joined into a continuous road (the *interpolant*), and that
road is sampled every ``dx / k`` for the solve. Every ``k``-th model point is a data sample, exactly.

**Interpolants** (:data:`INTERPOLANTS`), each periodic over the segment (the periodic model's
segments repeat, and are seamless: :meth:`roadtex.Profile.segments`):

- ``"pchip"`` (the default since 0.5.0): monotone piecewise cubic (Fritsch-Carlson,
  :class:`scipy.interpolate.PchipInterpolator`). It adds no height the data do not show: between two
  readings it stays between them, and a reading higher than its neighbours is a top with a level
  tangent, so the rubber rests on the stone's measured top, no higher. Its slope is continuous,
  like a stone's rounded top. Measured (issue 39, ``benches/interpolant_convergence.py``): its
  levels converge with the model grid about twice as fast in k as the linear road's (the same
  error at about half the k: 0.5 and 1 mm, four pavements, against k = 32 of each road; 1 mm
  surfaces one rung of k each way), so the job's budget is met on a grid half as fine.
- ``"linear"`` (the default until 0.4): straight lines between readings, what ISO 13473-1:2019
  (clause 7.3, drop-outs) uses between readings. It puts a corner at every reading, exactly where
  the rubber rests, and the contact pressure on a corner is singular, which a grid resolves slowly
  (error about k^-1.2).
- ``"bandlimited"``: the trigonometric interpolant (zero-padded DFT, :func:`scipy.signal.resample`):
  the road with no wavelength shorter than two samples; it overshoots near sharp tops.

Surfaces (heights ``[iy, ix]``, periodic both ways as the areal model's tiles are) are refined
``k_along`` times along the road and ``k_across`` times across it by the same interpolant along each
axis in turn (:func:`refine_periodic_surface`; ``"linear"`` is then bilinear, ``"pchip"`` the tensor product of
monotone cubics): every
(``k_across``-th row, ``k_along``-th column) point is a reading, and each data row is, on the
fine grid, exactly that row refined along the road as a line profile would be.

The spread of the converged levels between these is what the data's sampling cannot tell (see
:func:`roadtex.budget.study` and docs/guide/model-grid.md): it is stated apart from the numerical error.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from roadtex._checks import whole_number
from roadtex.errors import InvalidInputError

Interpolant = Literal["pchip", "linear", "bandlimited"]

#: The interpolants :func:`refine_periodic` knows, the default first.
INTERPOLANTS: tuple[str, ...] = ("pchip", "linear", "bandlimited")
#: The road between readings when none is named: the job's (``ProcessingOptions.interpolant``), the
#: pilots' and every function of this package that refines.
DEFAULT_INTERPOLANT: Interpolant = "pchip"

#: Readings carried over each end for the cubic interpolant (its slopes look two readings ahead).
PCHIP_PADDING = 3
#: The largest refinement: a model grid 64 times finer than the data's (0.5 mm data solved every
#: 8 um). The levels converge by k = 8 (the module docstring's table; budget.study climbs to 32 at
#: most); beyond 64 a refinement is a typo (``--refine 10000``), which allocated until the process died.
MAX_REFINE = 64
#: The most model-grid points of one segment (line) or one tile (surface, k_along x k_across times
#: its readings): 2**22, 32 MiB of heights, which the solver's arrays multiply several times.
MAX_MODEL_POINTS = 2**22


def check_refine(refine: object, name: str = "refine") -> int:
    """``refine`` as a whole number from 1 to :data:`MAX_REFINE` (the model grid is ``refine`` times
    finer than the data's)."""
    k = whole_number(refine, name, 1)
    if k > MAX_REFINE:
        raise InvalidInputError(f"{name} must be at most {MAX_REFINE} (a model grid {MAX_REFINE} times finer than the "
                                f"data's; levels converge by 8), got {k}")
    return k


def check_model_heights(z: np.ndarray, points: int, what: str) -> None:
    """Refuses readings the interpolants cannot join (NaN, infinite: drop-outs are filled by the
    conditioning first; each interpolant spread them differently) and a model grid of more than
    :data:`MAX_MODEL_POINTS` points (``points``: of one segment or tile), before allocating it."""
    bad = ~np.isfinite(z)
    if bad.any():
        first = np.unravel_index(int(np.argmax(bad)), z.shape)
        raise InvalidInputError(f"heights hold {int(bad.sum())} non-finite reading(s) (the first at index "
                                f"{tuple(int(i) for i in first)}: {z[first]!r}): the model grid joins readings, so "
                                "drop-outs must be filled first (roadtex.profiles.conditioning)")
    if points > MAX_MODEL_POINTS:
        raise InvalidInputError(f"the model grid of one {what} would hold {points} points, beyond {MAX_MODEL_POINTS}: "
                                "a smaller refinement or a shorter segment or tile")


def check_interpolant(interpolant: object) -> Interpolant:
    if interpolant not in INTERPOLANTS:
        raise InvalidInputError(f"interpolant must be one of {', '.join(map(repr, INTERPOLANTS))}, got {interpolant!r}")
    return interpolant  # type: ignore[return-value]


def refine_periodic(heights: np.ndarray, refine: int, interpolant: Interpolant = DEFAULT_INTERPOLANT) -> np.ndarray:
    """Periodic segments sampled every dx, on a grid ``refine`` times finer (every dx / refine).

    Args:
        heights: (..., N) heights (m) of periodic segments (the last axis repeats with period N dx).
        refine: k from 1 to :data:`MAX_REFINE`; k = 1 returns ``heights`` itself (the same array,
            not a copy).
        interpolant: the continuous road between readings, see the module docstring.

    Raises:
        InvalidInputError: a refinement beyond :data:`MAX_REFINE`, a segment's model grid beyond
            :data:`MAX_MODEL_POINTS` points, or (k > 1) a NaN or infinite reading.

    Returns:
        (..., N k) heights (m); point ``i k`` is reading ``i`` exactly (``"linear"``, ``"pchip"``;
        ``"bandlimited"`` to rounding), the others lie on the interpolant, the wrap from the last
        reading to the first included.
    """
    from scipy.interpolate import PchipInterpolator
    from scipy.signal import resample  # scipy on first use: the command line starts without it
    k = check_refine(refine)
    kind = check_interpolant(interpolant)
    z = np.asarray(heights, dtype=np.float64)
    if z.ndim < 1 or z.shape[-1] < 1:
        raise InvalidInputError(f"heights must hold at least one reading per segment, got shape {z.shape}")
    if k == 1:
        return z
    n = z.shape[-1]
    check_model_heights(z, n * k, "segment")
    if kind == "linear":
        following = np.roll(z, -1, axis=-1)
        step = (following - z)[..., None]
        fractions = np.arange(k, dtype=np.float64) / k
        # z_i + (z_{i+1} - z_i) j / k: the j = 0 point is z_i itself, bit for bit
        fine = z[..., None] + step * fractions
        return fine.reshape(*z.shape[:-1], n * k)
    if kind == "pchip":
        pad = min(PCHIP_PADDING, n)
        extended = np.concatenate([z[..., n - pad:], z, z[..., :pad]], axis=-1)
        positions = np.arange(-pad, n + pad, dtype=np.float64)
        fine_positions = np.arange(n * k, dtype=np.float64) / k
        fine = PchipInterpolator(positions, extended, axis=-1)(fine_positions)
        fine[..., ::k] = z   # the readings themselves, exactly
        return fine
    fine = resample(z, n * k, axis=-1)
    return fine


def refine_periodic_surface(heights: np.ndarray, k_along: int, k_across: int = 1,
                            interpolant: Interpolant = DEFAULT_INTERPOLANT) -> np.ndarray:
    """Periodic surfaces sampled every (dy, dx), on a grid ``k_across`` x ``k_along`` times finer.

    The tensor-product interpolant: :func:`refine_periodic` along the road (the last axis), then
    across it (the second last), so ``"linear"`` is bilinear.

    Args:
        heights: (..., ny, nx) heights (m), rows across the road (spacing dy), columns along it
            (dx), periodic both ways (the areal model's tiles).
        k_along, k_across: refinements from 1 to :data:`MAX_REFINE` along and across; (1, 1)
            returns ``heights`` itself.
        interpolant: as for :func:`refine_periodic`.

    Raises:
        InvalidInputError: as :func:`refine_periodic`, the points of a tile's model grid
            (``ny k_across nx k_along``) bounded by :data:`MAX_MODEL_POINTS`.

    Returns:
        (..., ny k_across, nx k_along) heights (m) every (dy / k_across, dx / k_along); point
        ``[i k_across, j k_along]`` is reading ``[i, j]``, and fine row ``i k_across`` is data row
        ``i`` refined along the road alone (``refine_periodic(heights[..., i, :], k_along)``).
    """
    along, across = check_refine(k_along, "k_along"), check_refine(k_across, "k_across")
    z = np.asarray(heights, dtype=np.float64)
    if z.ndim < 2:
        raise InvalidInputError(f"heights must have at least 2 axes (rows across, columns along), got shape {z.shape}")
    if along * across > 1:   # the product grows as k^2: checked before the first pass allocates
        check_model_heights(z, z.shape[-1] * along * z.shape[-2] * across, "tile")
    fine = refine_periodic(z, along, interpolant)
    if across == 1:
        return fine
    return np.swapaxes(refine_periodic(np.swapaxes(fine, -1, -2), across, interpolant), -1, -2).copy()


def coarse_points(fine: np.ndarray, refine: int) -> np.ndarray:
    """The model's values at the data's readings: every ``refine``-th point of (..., N k) arrays."""
    k = check_refine(refine)
    return fine if k == 1 else np.ascontiguousarray(fine[..., ::k])


def reading_means(fine: np.ndarray, refine: int) -> np.ndarray:
    """A periodic model field's (..., N k) mean over each reading's cell (..., N): the k model points
    nearest reading i (model point i k), the two at the cell's edges weighted 1/2 when k is even.
    For a pressure (Pa) this is the force on the reading's interval over its length: the cells tile
    the period, so the mean pressure (the load) is kept exactly, while the value at the readings
    (:func:`coarse_points`) samples the rubber where it rests on the road's tops, above the mean."""
    k = check_refine(refine)
    if k == 1:
        return fine
    values = np.asarray(fine, dtype=np.float64)
    half = k // 2
    total = np.zeros(values.shape[:-1] + (values.shape[-1] // k,))
    for offset in range(-half, half + 1):
        weight = 0.5 if k % 2 == 0 and abs(offset) == half else 1.0
        total += weight * np.roll(values, -offset, axis=-1)[..., ::k]
    return total / k


def prolong_pressure(coarse: np.ndarray, factor: int) -> np.ndarray:
    """A periodic pressure field (..., N) on the grid ``factor`` times finer (..., N factor), linear
    between the coarse points (coarse point i on fine point i factor): p >= 0 and the mean kept
    (each coarse value spreads over weights summing to ``factor``). A start for a finer solve of the
    same readings, as :func:`roadtex.contact_many`'s ``initial_pressure``; the same rule as the
    core's coarse start."""
    k = check_refine(factor, "factor")
    if k == 1:
        return coarse
    following = np.roll(coarse, -1, axis=-1)
    fine = np.empty(coarse.shape[:-1] + (coarse.shape[-1] * k,))
    for j in range(k):
        fine[..., j::k] = coarse + (following - coarse) * (j / k)
    return fine


def resample_periodic(heights: np.ndarray, points: int, interpolant: Interpolant = DEFAULT_INTERPOLANT) -> np.ndarray:
    """Periodic segments of N readings on a grid of ``points`` equal intervals per period (any count,
    not only a multiple of N): the road :func:`refine_periodic` joins the readings into, sampled at
    ``j N / points`` reading intervals, j = 0 .. points - 1.

    What it is for: the error pilot's reference is a sequence of ever finer grids of the same road
    (:func:`roadtex.budget.study.build_pilot`), and where N has a large prime factor (CAPTIF's 0.5 m
    segments: 13,337 points) every grid N k would be transformed by the slow FFT algorithm; a
    5-smooth count of points just above N k samples the same road, 1.4 to 1.8 times faster to solve.

    Args:
        heights: (..., N) heights (m) of periodic segments.
        points: the grid's points per period, at least 1 (``N k`` gives :func:`refine_periodic`'s
            grid, the same values to rounding).
        interpolant: as for :func:`refine_periodic`.

    Raises:
        InvalidInputError: ``points`` not a whole number from 1 to :data:`MAX_MODEL_POINTS`, or a NaN
            or infinite reading.

    Returns:
        (..., points) heights (m); grid point 0 is reading 0.
    """
    from scipy.interpolate import PchipInterpolator
    from scipy.signal import resample  # scipy on first use: the command line starts without it
    kind = check_interpolant(interpolant)
    count = whole_number(points, "points", 1)
    z = np.asarray(heights, dtype=np.float64)
    if z.ndim < 1 or z.shape[-1] < 1:
        raise InvalidInputError(f"heights must hold at least one reading per segment, got shape {z.shape}")
    n = z.shape[-1]
    check_model_heights(z, count, "segment")
    if kind == "bandlimited":
        return resample(z, count, axis=-1)
    positions = np.arange(count, dtype=np.float64) * (n / count)   # in reading intervals, in [0, n)
    if kind == "linear":
        left = np.minimum(np.floor(positions).astype(np.int64), n - 1)
        fraction = positions - left
        following = np.roll(z, -1, axis=-1)
        return z[..., left] + (following[..., left] - z[..., left]) * fraction
    pad = min(PCHIP_PADDING, n)
    extended = np.concatenate([z[..., n - pad:], z, z[..., :pad]], axis=-1)
    return PchipInterpolator(np.arange(-pad, n + pad, dtype=np.float64), extended, axis=-1)(positions)
