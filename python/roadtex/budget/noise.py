"""The error budget's constants: its default size and the bands it applies to (tyre/road noise).

**Band range.** Tyre/road noise is rated between 100 Hz and 5 kHz (the range the CPX and SPB
methods, ISO 11819-1/-2, report), at road speeds from 50 km/h (the urban reference speed) to
120 km/h (motorway). Texture of wavelength lambda excites f = V / lambda, so the wavelengths that
matter are V_min / f_max = 13.9 m/s / 5 kHz = 2.8 mm to V_max / f_min = 33.3 m/s / 100 Hz = 333 mm.
A band belongs to the budget when its wavelength range overlaps [2.8 mm, 333 mm] and it is reported
at the job's finest setting (segment length >= 12 centre wavelengths, centre >= 2.5 dx): for 0.5 m
segments of a 0.04 mm profile that is the third octaves 40 mm (n = 14) to 2.5 mm (n = 26). Shorter
reported bands (down to 0.1 mm at the CAPTIF sampling) are still computed and still get an error
estimate, but the budget does not constrain them: they lie above 5 kHz at every road speed.

**Default budget.** :data:`DEFAULT_ERROR_BUDGET_DB` = 0.2 dB: a tenth of the 2 dB that listeners
need to notice a change of a broadband noise, and below the repeatability of texture-level
measurements (a few tenths of a dB), yet large enough to leave the resampling floor measured on
the CAPTIF files (0.05 to 0.12 dB in the 2.5 to 3.15 mm bands as soon as the 0.0375 mm files are
resampled at all, see docs/guide/error-budget.md) some room.
"""

from __future__ import annotations

import numpy as np
import polars as pl

from roadtex.spectra.bands import BandKind, band_table

#: Largest numerical error (dB) allowed by default on any reported level in a budget band.
DEFAULT_ERROR_BUDGET_DB = 0.2

#: Tyre/road noise frequency range (Hz) the budget protects.
NOISE_FREQUENCY_RANGE = (100.0, 5000.0)

#: Road speeds (km/h) over which the noise range is mapped to wavelengths.
NOISE_SPEED_RANGE_KMH = (50.0, 120.0)


def noise_wavelength_range() -> tuple[float, float]:
    """(shortest, longest) texture wavelength (m) exciting the noise range at the speed range."""
    f_min, f_max = NOISE_FREQUENCY_RANGE
    v_min, v_max = (v / 3.6 for v in NOISE_SPEED_RANGE_KMH)
    return v_min / f_max, v_max / f_min


def budget_bands(dx: float, segment_length: float, kind: BandKind = "third_octave") -> pl.DataFrame:
    """The rows of :func:`roadtex.spectra.band_table` (``dx`` m, ``segment_length`` m) that the
    budget applies to: reported, and overlapping the noise wavelength range (see the module)."""
    table = band_table(dx, segment_length, kind)
    shortest, longest = noise_wavelength_range()
    return table.filter(pl.col("reported") & (pl.col("upper_wavelength") >= shortest)
                        & (pl.col("lower_wavelength") <= longest))


def in_budget(bands: np.ndarray, dx: float, segment_length: float, kind: BandKind = "third_octave") -> np.ndarray:
    """Boolean mask: which of the band numbers ``bands`` are budget bands (see :func:`budget_bands`)."""
    chosen = budget_bands(dx, segment_length, kind)["band"].to_numpy()
    return np.isin(np.asarray(bands), chosen)
