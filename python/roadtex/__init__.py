"""roadtex: how a tyre's rubber envelops a measured road texture profile.

The periodic INRETS contact model (Klein & Hamet) solved in Rust; SI units throughout.

>>> import numpy as np, roadtex
>>> z = 1e-4 * np.cos(2 * np.pi * np.arange(1024) / 1024)
>>> r = roadtex.contact(z, dx=1e-5, youngs_modulus=2.5e6, mean_pressure=2e5)
>>> bool(abs(r.pressure.mean() / 2e5 - 1) < 1e-12)
True

Subpackages, by concern: :mod:`roadtex.profiles` (the profile model, conditioning, segments,
readers, MPD, synthetic profiles), :mod:`roadtex.surfaces` (3D surfaces: the
Surface model, conditioning, lines, tiles, readers, synthetic surfaces), :mod:`roadtex.models` (contact, von Meier, Clapp, closed forms,
comparisons), :mod:`roadtex.spectra` (bands, levels, regressions, calibration),
:mod:`roadtex.budget` (the error budget: convergence study and pilot), :mod:`roadtex.archive`
(the bulk job), :mod:`roadtex.report`; errors in :mod:`roadtex.errors`.
"""

from roadtex import comparisons, errors
from roadtex._core import __version__
from roadtex.archive import ProcessingOptions, build_manifest, process, read_manifest, read_profiles
from roadtex.budget import BudgetChoice, choose_setting, convergence_study
from roadtex.errors import (
                            ArchiveWriteError,
                            ClappError,
                            CoarseSamplingWarning,
                            ConditioningWarning,
                            ConvergenceError,
                            DamagedResultsError,
                            ErrorBudgetWarning,
                            ImplausibleParameterWarning,
                            ImplausibleTextureWarning,
                            InternalError,
                            InvalidInputError,
                            JobInterrupted,
                            ManifestError,
                            MissingDependencyError,
                            OutputInUseError,
                            ProfileFormatError,
                            ResultsNotFoundError,
                            RoadtexError,
                            RoadtexWarning,
                            RunFailure,
                            SolverError,
                            UnitConflictWarning,
)
from roadtex.models import (
                            ClappResult,
                            ContactBatch,
                            ContactResult,
                            SurfaceBatch,
                            SurfaceResult,
                            clapp,
                            contact,
                            contact_many,
                            contact_surface,
                            contact_surface_many,
                            reference,
                            von_meier,
)
from roadtex.profiles import MpdResult, Profile, Segments, mpd, pavements, read_profile, synthetic, synthetic_pavement, write_profile
from roadtex.report import build_report
from roadtex.spectra import (
                            BandLevels,
                            CalibrationResult,
                            band_levels,
                            band_regressions,
                            band_table,
                            calibrate_modulus,
                            level_differences,
                            octave_levels,
                            pressure_levels,
                            third_octave_levels,
                            time_frequency,
                            with_time_frequency,
)
from roadtex.surfaces import Surface, read_surface, sett_surface, synthetic_surface

__all__ = [
    "__version__", "errors",
    "RoadtexError", "InvalidInputError", "ProfileFormatError", "ManifestError", "ConvergenceError", "SolverError",
    "ClappError", "InternalError", "ArchiveWriteError", "OutputInUseError", "ResultsNotFoundError", "DamagedResultsError",
    "MissingDependencyError", "JobInterrupted",
    "RunFailure", "RoadtexWarning", "ImplausibleTextureWarning", "ImplausibleParameterWarning", "ConditioningWarning",
    "ErrorBudgetWarning", "UnitConflictWarning", "CoarseSamplingWarning",
    "ContactBatch", "ContactResult", "contact", "contact_many", "von_meier", "ClappResult", "clapp",
    "SurfaceBatch", "SurfaceResult", "contact_surface", "contact_surface_many",
    "comparisons", "reference",
    "BandLevels", "band_levels", "band_regressions", "band_table", "level_differences", "octave_levels",
    "pressure_levels", "third_octave_levels", "time_frequency", "with_time_frequency",
    "CalibrationResult", "calibrate_modulus",
    "BudgetChoice", "choose_setting", "convergence_study",
    "ProcessingOptions", "build_manifest", "process", "read_manifest", "read_profiles", "build_report",
    "Profile", "Segments", "read_profile", "write_profile", "MpdResult", "mpd", "synthetic_pavement",
    "pavements", "synthetic", "Surface", "read_surface", "synthetic_surface", "sett_surface",
]
