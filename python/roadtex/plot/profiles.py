"""A profile with its enveloped profile(s) and contact pressure(s), as the contact model gives them."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from roadtex._checks import finite_number, positive
from roadtex.errors import InvalidInputError
from roadtex.plot.style import COLOURS, MM, MPA, legend_outside, modulus_label, new_axes


def _by_modulus(values, n: int, name: str) -> dict[float | None, np.ndarray]:
    """``values`` as {E (Pa) or None: array of n points}: one array, or a mapping from E to arrays."""
    if values is None:
        return {}
    items = values.items() if isinstance(values, Mapping) else [(None, values)]
    out = {}
    for e, v in items:
        array = np.asarray(v, dtype=float)
        if array.shape != (n,):
            raise InvalidInputError(f"{name} has shape {array.shape}; expected ({n},), the heights' shape")
        finite_array(array, name)
        out[None if e is None else float(e)] = array
    return out


def finite_array(array: np.ndarray, name: str) -> None:
    """Refuses an infinite value (NaN is a drop-out, drawn as a gap): matplotlib would leave it out
    without a word, or fail on the axis limits."""
    infinite = np.isinf(array)
    if infinite.any():
        first = np.unravel_index(int(np.argmax(infinite)), array.shape)
        raise InvalidInputError(f"{name} holds {int(infinite.sum())} infinite value(s), the first at index "
                                f"{tuple(int(i) for i in first)}: nothing to draw there (NaN is drawn as a gap)")


def _window(n: int, dx: float, window: float | None) -> slice:
    """The middle ``window`` metres of n points (all of them when None)."""
    if window is None:
        return slice(0, n)
    points = min(n, max(8, int(round(window / dx))))
    first = (n - points) // 2
    return slice(first, first + points)


def profile(heights, dx: float, *, envelope=None, pressure=None, x0: float = 0.0, window: float | None = None,
            label: str = "road profile", ax=None):
    """A road profile with its enveloped profile(s) and, below it, the contact pressure(s).

    Args:
        heights: the profile (m), N points at spacing ``dx``.
        dx: sampling interval (m).
        envelope: the enveloped profile (m, N points), or a mapping {E (Pa): enveloped profile} to draw
            several moduli, each labelled "E = ... MPa".
        pressure: the contact pressure (Pa, N points), or a mapping {E (Pa): pressure}; drawn on a
            second axes below, on a symmetric-log scale (it spans decades where contact is sparse).
        x0: position of the first point (m).
        window: draw only the middle ``window`` metres (so texture is visible at a glance); None: all.
        label: legend label of the profile.
        ax: draw into these axes (one Axes, or two when ``pressure`` is given) instead of a new figure.

    Returns:
        ``(fig, ax)``: ax is the height axes, or ``(height_ax, pressure_ax)`` when ``pressure`` is given.
        Distances are drawn in mm, heights in mm, pressures in MPa.
    """
    z = np.asarray(heights, dtype=float)
    if z.ndim != 1 or z.size < 2:
        raise InvalidInputError(f"heights must be a 1-D profile of at least 2 points; got shape {z.shape}")
    finite_array(z, "heights")
    dx = positive(dx, "dx", "m")
    x0 = finite_number(x0, "x0")
    window = None if window is None else positive(window, "window", "m")
    envelopes = _by_modulus(envelope, z.size, "envelope")
    pressures = _by_modulus(pressure, z.size, "pressure")
    fig, axes = new_axes(ax, rows=2 if pressures else 1, figsize=(8.0, 5.0 if pressures else 3.2))
    height_ax, pressure_ax = (axes[0], axes[1]) if pressures else (axes, None)
    view = _window(z.size, dx, window)
    x = (x0 + np.arange(z.size)[view] * dx) * MM
    height_ax.plot(x, z[view] * MM, color="0.3", lw=0.8, label=label)
    for colour, (e, values) in zip(COLOURS, envelopes.items()):
        height_ax.plot(x, values[view] * MM, color=colour, lw=1.0, label="enveloped" if e is None else modulus_label(e))
    height_ax.set_ylabel("height (mm)")
    if pressure_ax is None:
        if ax is None:  # into given axes, the caller labels its figure
            height_ax.set_xlabel("distance x (mm)")
            legend_outside(fig, height_ax)
        return fig, height_ax
    draw_pressure(pressure_ax, x, {e: p[view] for e, p in pressures.items()})
    if ax is None:
        pressure_ax.set_xlabel("distance x (mm)")
        legend_outside(fig)
    return fig, (height_ax, pressure_ax)


def draw_pressure(ax, x_mm: np.ndarray, pressures: Mapping[float | None, np.ndarray]) -> None:
    """Contact pressures (Pa) against distance (mm) on ``ax``, in MPa on a symmetric-log scale."""
    for colour, (e, values) in zip(COLOURS, pressures.items()):
        ax.plot(x_mm, values / MPA, color=colour, lw=0.9, label="pressure" if e is None else modulus_label(e))
    ax.set_yscale("symlog", linthresh=0.1)
    ax.set_ylabel("pressure p (MPa)")
