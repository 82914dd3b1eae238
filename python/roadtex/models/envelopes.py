"""Geometric envelopes that stand in for the elastic contact model, for comparison with it."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from roadtex import _core
from roadtex._checks import as_float_array, spacing_of, to_float
from roadtex.profiles.plausibility import warn_if_implausible_texture
from roadtex.profiles.profile import Profile


def von_meier(heights: Profile | np.ndarray | Sequence[float], dx: float | None = None, d_star: float = 54.0) -> np.ndarray:
    """The von Meier et al. envelope of a profile (m).

    The rubber sags into cavities as parabolas of bounded curvature: the result e is the lowest
    sequence with e >= heights and (e[i-1] - 2 e[i] + e[i+1]) / dx^2 <= 2 d_star at every interior
    point. It is computed exactly (to rounding) and without iteration, as the upper convex hull of
    heights - d_star (i dx)^2 plus d_star (i dx)^2, in O(N).

    Args:
        heights: profile heights (m), at least 3 points, no NaN; or a :class:`~roadtex.Profile`
            (equally spaced, no drop-outs), which carries its dx.
        dx: sampling interval (m); required with an array (with a Profile it may be left out;
            given, it must be the Profile's).
        d_star: curvature limit d* (1/m); the seed's 0.054 1/mm is 54 1/m. 0 gives the upper
            convex hull of the profile (a taut string).

    Returns:
        The envelope (m), same length as ``heights``; equal to them at both ends of every arc.

    Warns:
        ImplausibleTextureWarning: heights that cannot be a road texture in metres (in mm?).
    """
    values, dx_f, _ = spacing_of(heights, dx, "heights")
    z = as_float_array(values, "heights", 1)
    warn_if_implausible_texture(z, dx_f, "heights")
    return _core.von_meier(z, dx_f, to_float(d_star, "d_star"))
