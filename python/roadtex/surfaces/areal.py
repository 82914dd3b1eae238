"""Areal texture parameters of ISO 25178-2 (height and hybrid parameters) of a surface or tile.

Filter settings, stated because ISO 25178 parameters mean nothing without them:

- F-operation: the least-squares plane is removed (``remove_plane=True``, the default), then the
  heights are taken from their mean (the reference plane of ISO 25178-2).
- No S-filter and no L-filter (no ISO 16610-61 Gaussian, no nesting index): the parameters are
  those of the surface as sampled (the "primary" surface with its plane removed), limited at short
  wavelengths by the data's own spacing and at long ones by the area's extent. A tile of the bulk
  job already had its plane removed (:class:`~roadtex.surfaces.tiles.Tiles`).
- Slopes (Sdq, ISO 25178-2:2021 clause 4.4.2; Sdr, clause 4.4.3; clauses 4.3.1 and 4.3.2 of the
  2012 edition): the standard defines them with the continuous gradient. Its discrete form here
  is the two-point difference between neighbouring readings, (z[i, j+1] - z[i, j]) / dx along
  and (z[i+1, j] - z[i, j]) / dy across, at every point with both forward neighbours: the
  gradient of the surface joined by straight lines between readings (the model grid's "linear"
  road), the discrete Sdq and Sdr of Stout et al. (1993, EUR 15178 EN, the areal parameters' origin)
  and SurfaceTopography's ``rms_gradient`` default. At scanner resolution the choice matters: a
  wavelength of ``n`` samples has its slopes scaled by sin(pi/n)/(pi/n) by two-point differences
  (-10 % at 4 samples) and by sin(2 pi/n)/(2 pi/n) by central differences (-36 %), which this
  module used before.

Definitions (discrete, the integrals of ISO 25178-2 as means over the grid's valid points z):
Sa = mean|z|, Sq = sqrt(mean z^2), Ssk = mean z^3 / Sq^3, Sku = mean z^4 / Sq^4, Sp = max z,
Sv = |min z|, Sz = Sp + Sv, Sdq = sqrt(mean(zx^2 + zy^2)), Sdr = mean(sqrt(1 + zx^2 + zy^2) - 1)
(a ratio: 0.01 is 1 %). Heights in m, Sdq and Sdr dimensionless. Drop-outs (NaN) are left out of
every mean; a slope needs the point and both its forward neighbours.
"""

from __future__ import annotations

import numpy as np

from roadtex._checks import positive
from roadtex.errors import InvalidInputError

#: The parameters :func:`areal_parameters` returns, in order, with their units.
AREAL_PARAMETERS: dict[str, str] = {"sa": "m", "sq": "m", "ssk": "1", "sku": "1", "sp": "m", "sv": "m", "sz": "m",
                                    "sdq": "1", "sdr": "1"}
#: The filter settings, as the tables state them.
AREAL_FILTERS = "F: least-squares plane removed; no S-filter, no L-filter (ISO 25178-2 parameters of the sampled surface)"


def plane_removed(heights: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """``heights`` (rows across at ``dy``, columns along at ``dx``; m) less their least-squares
    plane over the valid (finite) points."""
    rows, columns = heights.shape
    y, x = np.meshgrid(dy * np.arange(rows), dx * np.arange(columns), indexing="ij")
    ok = np.isfinite(heights)
    xs, ys, zs = x[ok] - x[ok].mean(), y[ok] - y[ok].mean(), heights[ok]
    # the normal equations of z = a + b x + c y, centred: plain sums (no BLAS; see roadtex.profiles.trend)
    sxx, syy, sxy = np.sum(xs * xs), np.sum(ys * ys), np.sum(xs * ys)
    sxz, syz = np.sum(xs * (zs - zs.mean())), np.sum(ys * (zs - zs.mean()))
    det = sxx * syy - sxy * sxy
    b = (sxz * syy - syz * sxy) / det if det > 0 else (sxz / sxx if sxx > 0 else 0.0)
    c = (syz * sxx - sxz * sxy) / det if det > 0 else (syz / syy if syy > 0 else 0.0)
    return heights - (zs.mean() + b * (x - x[ok].mean()) + c * (y - y[ok].mean()))


def areal_parameters(surface: object, dx: float | None = None, dy: float | None = None, *,
                     remove_plane: bool = True) -> dict[str, float]:
    """ISO 25178-2 areal parameters Sa, Sq, Ssk, Sku, Sp, Sv, Sz, Sdq, Sdr of a surface.

    Args:
        surface: a :class:`~roadtex.surfaces.Surface`, or a 2-D array of heights (m; rows across
            the road at ``dy``, columns along it at ``dx``).
        dx, dy: the spacings (m) when ``surface`` is an array (a Surface carries its own).
        remove_plane: the F-operation: remove the least-squares plane first (default). The
            filters are stated in the module docstring (:data:`AREAL_FILTERS`).

    Returns:
        ``{"sa", "sq", "ssk", "sku", "sp", "sv", "sz" (m), "sdq", "sdr" (1)}`` as floats; Ssk and
        Sku are NaN on a flat surface (Sq no more than rounding of the heights).

    Raises:
        InvalidInputError: not a 2-D grid of at least 2 x 2 points, no spacing, an infinite height,
            or no valid point.
    """
    heights = getattr(surface, "heights", surface)
    dx = getattr(surface, "dx", dx)
    dy = getattr(surface, "dy", dy)
    if dx is None or dy is None:
        raise InvalidInputError("areal_parameters needs dx and dy (m) with an array of heights")
    dx, dy = positive(dx, "dx", "m"), positive(dy, "dy", "m")
    z = np.array(heights, dtype=np.float64)
    if z.ndim != 2 or min(z.shape) < 2:
        raise InvalidInputError(f"areal parameters need a 2-D grid of at least 2 x 2 heights, got shape {z.shape}")
    infinite = np.isinf(z)
    if infinite.any():
        first = np.unravel_index(int(np.argmax(infinite)), z.shape)
        raise InvalidInputError(f"heights hold {int(infinite.sum())} infinite value(s) (the first at "
                                f"{tuple(int(i) for i in first)}): a height is a finite number of metres, or NaN for "
                                "a drop-out")
    if not np.isfinite(z).any():
        raise InvalidInputError("areal parameters need at least one valid (finite) height")
    # what is left of a plane after removing it is rounding: at most a few ulps of the heights
    rounding = 1e3 * np.finfo(np.float64).eps * float(np.nanmax(np.abs(z)))
    if remove_plane:
        z = plane_removed(z, dx, dy)
    z = z - np.nanmean(z)
    valid = z[np.isfinite(z)]
    sq = float(np.sqrt(np.mean(valid ** 2)))
    flat = sq <= rounding
    ssk = float("nan") if flat else float(np.mean(valid ** 3) / sq ** 3)
    sku = float("nan") if flat else float(np.mean(valid ** 4) / sq ** 4)
    # two-point differences to the forward neighbours (the module docstring), on the (ny-1, nx-1) points having both
    zx = np.diff(z, axis=1)[:-1, :] / dx
    zy = np.diff(z, axis=0)[:, :-1] / dy
    slope2 = zx ** 2 + zy ** 2
    slope2 = slope2[np.isfinite(slope2)]
    sp, sv = float(valid.max()), float(-valid.min())
    return {"sa": float(np.mean(np.abs(valid))), "sq": sq, "ssk": ssk, "sku": sku, "sp": sp, "sv": sv, "sz": sp + sv,
            "sdq": float(np.sqrt(np.mean(slope2))) if slope2.size else float("nan"),
            "sdr": float(np.mean(np.sqrt(1.0 + slope2) - 1.0)) if slope2.size else float("nan")}
