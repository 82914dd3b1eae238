"""Positions for heights-only data: a grid of the given dx."""

from __future__ import annotations

import numpy as np

from roadtex._checks import finite_number, positive
from roadtex.errors import ProfileFormatError


def grid_positions(n: int, options: dict, name: str) -> np.ndarray:
    if options.get("dx") is None:
        raise ProfileFormatError(f"{name}: heights only (no distance column): give dx, the sampling interval in m "
                                 "(a read_profile option, the manifest column dx or roadtex process --input-dx)")
    dx = positive(options["dx"], "dx")
    return finite_number(options.get("start", 0.0), "start") + dx * np.arange(n)
