"""Clapp's tyre/road contact model: the finite, sub-profile baseline the INRETS report compares with.

Units are SI: heights and dx in metres, moduli and pressures in pascals.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from roadtex import _core
from roadtex._checks import as_float_array, positive_int, to_float, warn_if_implausible_rubber, whole_number
from roadtex.models.results import ContactMeasures
from roadtex.profiles.plausibility import warn_if_implausible_texture


@dataclass(frozen=True)
class ClappResult(ContactMeasures):
    """Clapp's model on one profile.

    Attributes:
        heights: the road profile z (m), as given.
        dx: element width (m).
        pressure: element pressures p (Pa), >= 0, mean equal to ``mean_pressure``: the model's
            main output.
        envelope: the enveloped profile (m): straight lines between consecutive contact elements,
            never below ``heights`` and equal to them on contact. Not an elastic surface.
        youngs_modulus, poisson, mean_pressure: the rubber and load (Pa, -, Pa).
        sub_profile, overlap, wrap: how the profile was cut (see :func:`clapp`).
        sub_profiles: number of sub-profiles (windows) solved.
        sweeps: the most active-set sweeps any sub-profile needed.
    """

    heights: np.ndarray
    dx: float
    pressure: np.ndarray
    envelope: np.ndarray
    youngs_modulus: float
    poisson: float
    mean_pressure: float
    sub_profile: int
    overlap: int
    wrap: bool
    sub_profiles: int
    sweeps: int

    @property
    def parameters(self) -> dict[str, Any]:
        """The inputs and cutting choices, for tables and figure captions."""
        return {
            "model": "clapp",
            "dx": self.dx,
            "points": int(self.heights.size),
            "youngs_modulus": self.youngs_modulus,
            "poisson": self.poisson,
            "mean_pressure": self.mean_pressure,
            "sub_profile": self.sub_profile,
            "overlap": self.overlap,
            "wrap": self.wrap,
            "sub_profiles": self.sub_profiles,
            "sweeps": self.sweeps,
        }


def clapp(
    heights: np.ndarray | Sequence[float],
    dx: float,
    youngs_modulus: float,
    mean_pressure: float,
    *,
    poisson: float = 0.5,
    sub_profile: int = 1024,
    overlap: int = 256,
    wrap: bool = False,
) -> ClappResult:
    """Clapp's model: the profile, cut into overlapping sub-profiles, each pressed as a rigid
    indenter into an elastic half-space (plane strain), solved one by one.

    On each sub-profile the displacement follows the seed's equation (2.1), the log kernel with an
    unknown constant c0 (the rigid approach), discretised exactly with non-periodic influence
    coefficients of piecewise-constant pressure on the elements; the contact zone comes from an
    active-set loop on the small dense system. Choices where the seed leaves the detail open:

    - **Cutting.** Windows of ``sub_profile`` points overlap each neighbour by ``overlap`` points on
      each side; only each window's central ``sub_profile - 2 * overlap`` points (its core) are
      kept, and the cores tile the profile. Windows are solved in parallel (Rust, GIL released).
    - **Load.** Equilibrium (2.2) holds on each core: every window is pressed until its core
      carries P times the core's length, so the whole profile carries exactly P L. (Loading each
      whole window with P times its length and rescaling was rejected: a finite window sags like a
      flat punch, its core gets too little load and too narrow contact patches, 25 % L1 error on
      Westergaard's surface.) Consequence: load cannot move between cores, so texture longer than
      a core is not carried as in the periodic model.
    - **Ends.** ``wrap=False`` (default): the end windows sit flush with the profile's ends, so
      the ends show the edge effect of a finite sample. ``wrap=True``: the profile is taken as
      periodic when cutting, the fair setting against the periodic model. A profile of at most
      ``sub_profile`` points is one window: the result is then the finite model,
      ``roadtex.contact(..., periodic=False)``.
    - **Envelope.** As the seed draws it: straight lines between consecutive contact elements
      (the asperities bounding each valley not totally enveloped), raised to the profile where a
      line would pass below it; flat beyond the first and last contact (with ``wrap``, the line
      from the last contact round to the first).

    Accuracy (tests): on Westergaard's wavy surface, L1 pressure error within 4.5 % of the exact
    solution with the default core of half the window (1.5 % with a quarter), at any wavelength the
    window spans; it is a baseline, not a rival to :func:`roadtex.contact`.

    Args:
        heights: profile heights z (m), positive up, on N >= 8 equal elements.
        dx: element width (m).
        youngs_modulus: E of the rubber (Pa).
        mean_pressure: P, the mean contact pressure (Pa).
        poisson: nu in (-1, 0.5]; E* = E / (1 - nu^2).
        sub_profile: points per sub-profile (default 1024, i.e. 51 mm at 0.05 mm: it spans the
            macrotexture). At least 8.
        overlap: points shared with each neighbour, on each side; less than half of
            ``sub_profile``. Default 256 (the core is half the window).
        wrap: take the profile as periodic when cutting the end windows.

    Returns:
        A :class:`ClappResult`.

    Raises:
        ValueError: bad input, with the argument and the problem named (the same checks and
            messages as :func:`roadtex.contact`).
    """
    z = as_float_array(heights, "heights", 1)
    dx_f, e_f, p_f, nu_f = (to_float(dx, "dx"), to_float(youngs_modulus, "youngs_modulus"),
                            to_float(mean_pressure, "mean_pressure"), to_float(poisson, "poisson"))
    sub = positive_int(sub_profile, "sub_profile")
    lap = whole_number(overlap, "overlap", 0)
    if np.isfinite(z).all():
        warn_if_implausible_texture(z, dx_f, "heights")
    warn_if_implausible_rubber(e_f, p_f)
    pressure, envelope, count, sweeps = _core.clapp(z, dx_f, e_f, nu_f, p_f, sub, lap, bool(wrap))
    return ClappResult(z, dx_f, pressure, envelope, e_f, nu_f, p_f, sub, lap, bool(wrap), count, sweeps)
