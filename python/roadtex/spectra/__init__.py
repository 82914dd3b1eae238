"""Texture and contact-pressure spectra in octave and one-third-octave wavelength bands (ISO 13473-4),
level differences, regressions, and the choice of the rubber modulus from noise data.

- :mod:`roadtex.spectra.bands`: band numbering, labels, reporting limits (:func:`band_table`);
- :mod:`roadtex.spectra.levels`: band levels of profiles and pressures (the DFT method, or the filter
  method with ``method="filter"``);
- :mod:`roadtex.spectra.filters`: the class-1 band filters of the filter method (ISO 13473-4:2024);
- :mod:`roadtex.spectra.analysis`: frequencies at a speed, level differences, regressions;
- :mod:`roadtex.spectra.calibration`: :func:`calibrate_modulus`.
"""

from roadtex.spectra.analysis import band_regressions, level_differences, time_frequency, with_time_frequency
from roadtex.spectra.bands import (
                                   BAND_COLUMNS,
                                   FREQUENCY_COLUMNS,
                                   MIN_POINTS,
                                   MIN_POINTS_PER_WAVELENGTH,
                                   MIN_WAVELENGTHS_PER_LENGTH,
                                   OCTAVE_BANDS,
                                   REFERENCE_PRESSURE,
                                   REFERENCE_TEXTURE,
                                   THIRD_OCTAVE_BANDS,
                                   BandKind,
                                   Detrend,
                                   Window,
                                   band_table,
                                   nominal_label,
)
from roadtex.spectra.calibration import DEFAULT_MODULI, MIN_SITES, CalibrationResult, calibrate_modulus
from roadtex.spectra.levels import BandLevels, band_levels, octave_levels, pressure_levels, third_octave_levels

__all__ = ["BAND_COLUMNS", "FREQUENCY_COLUMNS", "MIN_POINTS", "MIN_POINTS_PER_WAVELENGTH", "MIN_WAVELENGTHS_PER_LENGTH",
           "OCTAVE_BANDS", "REFERENCE_PRESSURE", "REFERENCE_TEXTURE", "THIRD_OCTAVE_BANDS", "BandKind", "Detrend",
           "Window", "band_table", "nominal_label", "BandLevels", "band_levels", "octave_levels", "pressure_levels",
           "third_octave_levels", "band_regressions", "level_differences", "time_frequency", "with_time_frequency",
           "DEFAULT_MODULI", "MIN_SITES", "CalibrationResult", "calibrate_modulus"]
