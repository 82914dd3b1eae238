"""roadtex: how a tyre's rubber envelops a measured road texture profile.

The periodic INRETS contact model (Klein & Hamet) solved in Rust; SI units throughout.

>>> import numpy as np, roadtex
>>> z = 1e-4 * np.cos(2 * np.pi * np.arange(1024) / 1024)
>>> r = roadtex.contact(z, dx=1e-5, youngs_modulus=2.5e6, mean_pressure=2e5)
>>> bool(abs(r.pressure.mean() / 2e5 - 1) < 1e-12)
True
"""

from roadtex._core import __version__
from roadtex.contact import (ContactBatch, ContactResult, ConvergenceError, ImplausibleTextureWarning, RoadtexWarning,
                             contact, contact_many)
from roadtex.envelopes import von_meier
from roadtex.clapp import ClappResult, clapp
from roadtex.spectra import (BandLevels, band_levels, band_regressions, band_table, level_differences, octave_levels,
                             pressure_levels, third_octave_levels, time_frequency, with_time_frequency)
from roadtex.calibration import CalibrationResult, calibrate_modulus
from roadtex.archive import ProcessingOptions, build_manifest, process, read_manifest, read_profiles
from roadtex.report import build_report

__all__ = ["ContactBatch", "ContactResult", "ConvergenceError", "ImplausibleTextureWarning", "RoadtexWarning", "contact", "contact_many", "von_meier", "__version__",
           "ClappResult", "clapp",
           "BandLevels", "band_levels", "band_regressions", "band_table", "level_differences", "octave_levels",
           "pressure_levels", "third_octave_levels", "time_frequency", "with_time_frequency",
           "CalibrationResult", "calibrate_modulus",
           "ProcessingOptions", "build_manifest", "process", "read_manifest", "read_profiles", "build_report"]

# Road profiles (issue 4). Note: ``roadtex.mpd`` is the function; the module stays importable.
from roadtex.profile import Profile, Segments, read_profile, write_profile  # noqa: E402
from roadtex.mpd import MpdResult, mpd  # noqa: E402
from roadtex.pavements import synthetic_pavement  # noqa: E402

__all__ += ["Profile", "Segments", "read_profile", "write_profile", "MpdResult", "mpd", "synthetic_pavement"]
