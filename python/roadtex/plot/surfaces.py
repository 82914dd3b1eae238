"""A 3D surface (heights, enveloped surface or pressure map) as a map with equal axis scales."""

from __future__ import annotations

import numpy as np

from roadtex._checks import finite_number, positive
from roadtex.errors import InvalidInputError
from roadtex.plot.profiles import finite_array
from roadtex.plot.style import MM, MPA, new_axes

#: What each kind of map shows: (scale from SI, colour-bar label, colour map).
KINDS = {"height": (MM, "height (mm)", "viridis"), "envelope": (MM, "enveloped height (mm)", "viridis"),
         "pressure": (1 / MPA, "contact pressure (MPa)", "magma")}


def surface_map(values, dx: float, dy: float | None = None, *, kind: str = "height", x0: float = 0.0, y0: float = 0.0,
                title: str | None = None, ax=None):
    """A surface's heights, enveloped surface or pressure map, ``values[iy, ix]``, with equal scales on
    both axes (a millimetre across is a millimetre along) and a colour bar.

    Args:
        values: 2-D array, rows across the road (y, spacing ``dy``), columns along it (x, spacing ``dx``);
            heights in m, or pressures in Pa with ``kind="pressure"``. NaN (drop-outs) is left blank.
        dx, dy: spacings along and across (m); ``dy`` None: ``dx``.
        kind: "height", "envelope" (drawn in mm) or "pressure" (drawn in MPa).
        x0, y0: position of the first column and row (m).
        title: the axes' title.
        ax: draw into this axes instead of a new figure.

    Returns:
        ``(fig, ax)``; the colour bar is ``ax.images[0].colorbar``.
    """
    array = np.asarray(values, dtype=float)
    if array.ndim != 2 or min(array.shape) < 2:
        raise InvalidInputError(f"values must be a 2-D map of at least 2 x 2 points; got shape {array.shape}")
    if kind not in KINDS:
        raise InvalidInputError(f"kind must be one of {sorted(KINDS)}; got {kind!r}")
    finite_array(array, "values")
    dx = positive(dx, "dx", "m")
    dy = dx if dy is None else positive(dy, "dy", "m")
    x0, y0 = finite_number(x0, "x0"), finite_number(y0, "y0")
    scale, label, cmap = KINDS[kind]
    ny, nx = array.shape
    # pixel edges: each value covers its dx x dy element
    extent = ((x0 - dx / 2) * MM, (x0 + (nx - 0.5) * dx) * MM, (y0 - dy / 2) * MM, (y0 + (ny - 0.5) * dy) * MM)
    width, height = (nx * dx, ny * dy)
    fig, ax = new_axes(ax, figsize=(8.0, max(2.0, min(8.0, 6.5 * height / width + 1.0))))
    image = ax.imshow(array * scale, origin="lower", extent=extent, cmap=cmap, aspect="equal", interpolation="nearest")
    fig.colorbar(image, ax=ax, label=label, shrink=0.8 if height < 0.3 * width else 1.0)  # a strip: a shorter bar
    ax.set(xlabel="x along the road (mm)", ylabel="y across (mm)")
    if title:
        ax.set_title(title)
    return fig, ax
