"""What every roadtex figure shares: colours, units on the axes (mm, MPa, dB with its reference),
the moduli's labels and one legend outside the axes. The report's figures use the same."""

from __future__ import annotations

from typing import Any

import numpy as np

from roadtex.spectra.bands import REFERENCE_PRESSURE, REFERENCE_TEXTURE

MM = 1e3
MPA = 1e6
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#17becf", "#7f7f7f")
#: The references of the levels, as every level axis and table column states them.
TEXTURE_DB = f"dB re {REFERENCE_TEXTURE * 1e6:g} µm"
PRESSURE_DB = f"dB re {REFERENCE_PRESSURE:g} Pa"


def plain(value: float, digits: int = 3) -> str:
    """``value`` to ``digits`` significant digits in positional notation, never with an exponent
    (2.5e6 -> "2500000", 2.5 -> "2.5", 0.0375 -> "0.0375"); "n/a" for NaN."""
    if not np.isfinite(value):
        return "n/a" if np.isnan(value) else ("inf" if value > 0 else "-inf")
    return np.format_float_positional(float(value), precision=digits, unique=True, fractional=False, trim="-")


def megapascals(value: float) -> str:
    """A modulus or pressure in Pa written in MPa: 2.5e6 -> "2.5 MPa"."""
    return f"{plain(value / MPA, 4)} MPa"


def modulus_label(e: float) -> str:
    """"E = 2.5 MPa" for ``e`` = 2.5e6 Pa."""
    return f"E = {megapascals(e)}"


def legend_outside(fig, ax=None, **kwargs):
    """One legend for the figure, outside every axes (right, top aligned), with the labelled artists
    of ``ax`` (an axes or a list of them, the first artist of each label kept; default: of all
    axes, each label once). Needs a figure with constrained layout."""
    handles: dict[str, Any] = {}
    for source in (fig.axes if ax is None else list(ax) if isinstance(ax, (list, tuple)) else [ax]):
        for handle, label in zip(*source.get_legend_handles_labels()):
            handles.setdefault(label, handle)
    return fig.legend(list(handles.values()), list(handles), loc="outside right upper", **kwargs)


def new_axes(ax, *, rows: int = 1, figsize: tuple[float, float] = (8.0, 3.2), sharex: bool = True):
    """``(fig, ax)`` for a plotting function: the figure of the given axes, or a new figure (constrained
    layout) with ``rows`` axes stacked (an array when ``rows`` > 1)."""
    if ax is not None:
        first = ax[0] if isinstance(ax, (list, tuple, np.ndarray)) else ax
        return first.figure, ax
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(rows, 1, figsize=figsize, sharex=sharex, squeeze=True, layout="constrained")
    return fig, axes
