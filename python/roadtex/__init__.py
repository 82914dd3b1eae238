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

The public names below are imported on first use (PEP 562 module ``__getattr__``): ``import
roadtex`` loads the Rust core and the errors only, so that ``roadtex --version`` and ``--help``
answer without loading polars, scipy and matplotlib (issue 39). Every name of ``__all__`` is
reachable as before (``roadtex.contact``, ``from roadtex import contact``), and listed by ``dir``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from roadtex import errors
from roadtex._core import __version__
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

if TYPE_CHECKING:   # the same names for type checkers and the docs' static analysis (griffe)
    from roadtex import comparisons
    from roadtex.archive import ProcessingOptions, build_manifest, process, read_manifest, read_profiles
    from roadtex.budget import BudgetChoice, choose_setting, convergence_study
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
    from roadtex.profiles import (
                                  MpdResult,
                                  Profile,
                                  Segments,
                                  mpd,
                                  pavements,
                                  read_profile,
                                  synthetic,
                                  synthetic_pavement,
                                  write_profile,
    )
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

#: The subpackage each lazily imported public name comes from.
_LAZY: dict[str, str] = {
    **dict.fromkeys(("ProcessingOptions", "build_manifest", "process", "read_manifest", "read_profiles"),
                    "roadtex.archive"),
    **dict.fromkeys(("BudgetChoice", "choose_setting", "convergence_study"), "roadtex.budget"),
    **dict.fromkeys(("ClappResult", "ContactBatch", "ContactResult", "SurfaceBatch", "SurfaceResult", "clapp",
                     "contact", "contact_many", "contact_surface", "contact_surface_many", "reference", "von_meier"),
                    "roadtex.models"),
    **dict.fromkeys(("MpdResult", "Profile", "Segments", "mpd", "pavements", "read_profile", "synthetic",
                     "synthetic_pavement", "write_profile"), "roadtex.profiles"),
    "build_report": "roadtex.report",
    **dict.fromkeys(("BandLevels", "CalibrationResult", "band_levels", "band_regressions", "band_table",
                     "calibrate_modulus", "level_differences", "octave_levels", "pressure_levels",
                     "third_octave_levels", "time_frequency", "with_time_frequency"), "roadtex.spectra"),
    **dict.fromkeys(("Surface", "read_surface", "sett_surface", "synthetic_surface"), "roadtex.surfaces"),
}

#: Subpackages reachable as attributes once ``roadtex`` is imported (``roadtex.plot.levels(...)``),
#: as they were when this module imported them all.
_SUBPACKAGES = ("archive", "budget", "comparisons", "models", "plot", "profiles", "report", "spectra", "surfaces")


def __getattr__(name: str) -> Any:
    """A public name or subpackage, imported on first use and kept (PEP 562)."""
    if name in _LAZY:
        package = importlib.import_module(_LAZY[name])
        # a module of the subpackage (reference, synthetic, pavements) is imported as `from
        # package import name` would: it is an attribute only once something imported it
        value = getattr(package, name) if hasattr(package, name) else importlib.import_module(f"{_LAZY[name]}.{name}")
    elif name in _SUBPACKAGES:
        value = importlib.import_module(f"roadtex.{name}")
    else:
        raise AttributeError(f"module 'roadtex' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__) | set(_SUBPACKAGES))


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
