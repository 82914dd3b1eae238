"""Figures of roadtex's results, drawn with matplotlib: each function returns ``(fig, ax)`` for the
caller to adjust, save or show, and the report draws its profile, spectra and surface figures with
the same functions. Distances and heights are drawn in mm, pressures in MPa, levels in dB with their
reference; the inputs are in SI units, as everywhere in roadtex.

>>> import numpy as np, roadtex, roadtex.plot
>>> z = 1e-4 * np.cos(2 * np.pi * np.arange(1024) / 1024)
>>> r = roadtex.contact(z, dx=1e-5, youngs_modulus=2.5e6, mean_pressure=2e5)
>>> fig, (height_ax, pressure_ax) = roadtex.plot.profile(z, 1e-5, envelope=r.envelope, pressure=r.pressure)
"""

from roadtex.plot.levels import band_levels, mean_level_error, speed_vs_error
from roadtex.plot.profiles import profile
from roadtex.plot.surfaces import surface_map

__all__ = ["profile", "band_levels", "mean_level_error", "surface_map", "speed_vs_error"]
