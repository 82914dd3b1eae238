"""Every exception and warning roadtex raises, in one hierarchy.

Catch :class:`RoadtexError` for anything roadtex refuses or fails at, and filter
:class:`RoadtexWarning` for anything it warns about. Each class also derives from the built-in
exception a caller would expect (bad input is a ``ValueError``, a solver that could not do what
was asked a ``RuntimeError``, an output that could not be written an ``OSError``), so code that
catches those keeps working.

This module imports nothing from roadtex: every other module, and the Rust binding, may use it.
"""

from __future__ import annotations


class RoadtexError(Exception):
    """Base of every error roadtex raises on purpose."""


class InvalidInputError(RoadtexError, ValueError):
    """An argument is unusable: the message names the argument, the problem and, for a
    magnitude, the unit expected."""


class ProfileFormatError(InvalidInputError):
    """A file cannot be read as a road profile or surface; the message starts with the file's name."""


class ManifestError(InvalidInputError):
    """The manifest is unreadable or has unknown, missing or inconsistent columns."""


class ConvergenceError(RoadtexError, RuntimeError):
    """The contact solver stopped before reaching ``tol`` (``raise_on_nonconvergence=True``)."""


class SolverError(RoadtexError, RuntimeError):
    """The dense direct contact solver could not settle on a contact set (never expected on valid input)."""


class ClappError(RoadtexError, RuntimeError):
    """Clapp's sub-profile model could not solve a window (never expected on valid input)."""


class InternalError(RoadtexError, RuntimeError):
    """A bug in roadtex: the Rust core panicked. The message is the panic's; please report it."""


class ArchiveWriteError(RoadtexError, OSError):
    """Output could not be written (unwritable folder, full disk): the job stops, nothing is corrupted."""


class OutputInUseError(ArchiveWriteError):
    """Another job is writing the output folder (its lock is held): the message names the holder
    (pid, host, start time)."""


class RunFailure(RoadtexError):
    """One run of a bulk job failed at ``stage`` (read, condition, mpd, segment, spectra, solve)
    because of ``cause``; the job records it in errors.parquet and goes on."""

    def __init__(self, stage: str, cause: BaseException):
        super().__init__(f"{stage}: {cause}")
        self.stage, self.cause = stage, cause


class ResultsNotFoundError(RoadtexError, FileNotFoundError):
    """A results folder lacks what was asked of it (not processed, or processed without the option
    that writes it)."""


class DamagedResultsError(RoadtexError, ValueError):
    """A job's output file cannot be trusted: it cannot be read, or its bytes differ from the
    checksum the job recorded when it wrote it (changed or damaged since). The message names the
    file; processing the manifest again rebuilds it."""


class MissingDependencyError(RoadtexError, ImportError):
    """An optional dependency is needed for what was asked (the message says which extra to install)."""


class JobInterrupted(KeyboardInterrupt):
    """The bulk job was interrupted (Ctrl-C) after ``done`` of ``runs`` runs: the runs finished so
    far are complete on disk, no temporary file is left, and the same call again resumes. A
    ``KeyboardInterrupt`` (not a :class:`RoadtexError`), so that code stopping on Ctrl-C still stops."""

    def __init__(self, done: int, runs: int):
        super().__init__(f"interrupted after {done} of {runs} runs; run the same command again to resume")
        self.done, self.runs = done, runs


class RoadtexWarning(UserWarning):
    """Base of roadtex's warnings: something was computed, but probably not what was meant."""


class ImplausibleTextureWarning(RoadtexWarning):
    """Heights that cannot be a road texture in metres (usually heights in mm or um given as m)."""


class CoarseSamplingWarning(RoadtexWarning):
    """A file sampled more coarsely than texture profilometers sample (above 5 mm), whose distance
    unit is certain (OpenCRG, a unit its header states, or one given for it): processed as read, and
    only the bands its sampling resolves are reported."""


class ImplausibleParameterWarning(RoadtexWarning):
    """A modulus, pressure or sampling interval far outside what tyres and road profiles have
    (usually a unit mistake: MPa given as Pa, mm as m)."""


class ErrorBudgetWarning(RoadtexWarning):
    """The error budget cannot be met at the data's sampling: the job runs near the smallest
    reachable error and states it per band."""


class UnitConflictWarning(RoadtexWarning):
    """A unit was given for a file column whose header states another: the header's unit is used
    (a given unit fills in only where the header states none)."""


class ConditioningWarning(RoadtexWarning):
    """Conditioning removed more of a profile than a sound measurement would need (trimmed length,
    spikes, drop-outs beyond the documented thresholds)."""


__all__ = [
    "RoadtexError", "InvalidInputError", "ProfileFormatError", "ManifestError", "ConvergenceError", "SolverError",
    "ClappError", "InternalError", "ArchiveWriteError", "OutputInUseError", "ResultsNotFoundError",
    "DamagedResultsError", "MissingDependencyError", "RunFailure", "JobInterrupted",
    "RoadtexWarning", "ImplausibleTextureWarning", "ImplausibleParameterWarning", "ConditioningWarning",
    "CoarseSamplingWarning",
    "ErrorBudgetWarning", "UnitConflictWarning",
]
