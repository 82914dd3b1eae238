"""Bulk reprocessing of road-survey archives: a manifest in, Parquet tables out.

The job reads, conditions and segments each run (one profile file), solves the periodic contact
problem for every segment and every requested Young's modulus in the Rust core, computes band
levels and mean profile depth, and writes tables (schemas below). It is built to be left alone:

- **Per-run atomic outputs.** Each run's tables go to ``OUT/runs/<run_id>/``. Every file is written
  to a temporary name and renamed into place; the run's ``status.json`` is renamed in last, so a
  run counts as done only when all its files are complete. A job killed at any moment (SIGKILL
  included) loses at most the runs in flight.
- **Resume and change detection.** ``status.json`` records a fingerprint of the processing options
  and the SHA-256 of the input file. A re-run skips every run whose fingerprint still matches and
  recomputes the others (changed options, changed or new files). Results do not depend on the
  thread count, the engine or the order in which runs finish, so a resumed job ends with tables
  identical to an uninterrupted one.
- **Bad runs.** A run that cannot be read or solved is recorded (``errors.parquet``) and the job
  goes on. Failures to *write* output (unwritable folder, full disk) stop the job with a clear
  :class:`roadtex.errors.ArchiveWriteError`; what was already written stays intact.
- **Bounded memory.** Runs are streamed one at a time (or one per Dask worker) and long runs are
  solved in chunks of segments.

Combined tables in ``OUT`` (rewritten atomically at the end of every job, in manifest order):

``segments.parquet`` — one row per (run, segment, modulus), :data:`SEGMENT_SCHEMA`; surface runs
(:mod:`~roadtex.archive.surface_run`) add a row per (model, tile, line, modulus): ``model`` "line" or "areal".
``bands.parquet`` — one row per (run, segment, modulus, band), :data:`BAND_SCHEMA` (surface runs: per
(model, tile, line, modulus, band)).
``errors.parquet`` — one row per failed run, :data:`ERROR_SCHEMA`.
``runs.parquet`` — one row per processed run (points, length, MPD of the whole run), :data:`RUN_SCHEMA`.
``examples.parquet`` — each run's middle segment, solved at every modulus, :data:`EXAMPLE_SCHEMA` (for the report).
``surface_examples.parquet`` — each surface run's middle tile at the middle modulus: heights, enveloped
surface, pressure map, :data:`SURFACE_EXAMPLE_SCHEMA` (for the report).
``edge_effect.parquet`` — the seed's figure 3.1 at the job's load, :data:`EDGE_EFFECT_SCHEMA`.
``parameters.json`` — the options, their fingerprint, the plan and the software versions.
``plan/`` — the pilots kept for the next job (:mod:`~roadtex.archive.kept_pilots`).
Profiles (``keep_profiles=True``): ``OUT/runs/<run_id>/profiles.parquet`` per run, schema
:data:`PROFILE_SCHEMA`; :func:`read_profiles` reads them back by run and position.

Modules, in the order data flows: :mod:`~roadtex.archive.options` (what the user asks),
:mod:`~roadtex.archive.manifest`, :mod:`~roadtex.archive.reading` (a row's reader and group),
:mod:`~roadtex.archive.plan` (what the job decided: :class:`JobPlan`, one :class:`RunPlan` per run),
:mod:`~roadtex.archive.planning` (the pilots that make it) and :mod:`~roadtex.archive.kept_pilots` (the
plan kept in ``OUT/plan/`` and reused), :mod:`~roadtex.archive.compute` (one line run),
:mod:`~roadtex.archive.surface_run` (one surface run: areal and line models),
:mod:`~roadtex.archive.tables` (segment and band rows for both), :mod:`~roadtex.archive.worker` (one run:
skip or compute, and its files), :mod:`~roadtex.archive.store` (atomic files, status),
:mod:`~roadtex.archive.engines` (local, Dask, progress), :mod:`~roadtex.archive.combined` (the combined
tables), :mod:`~roadtex.archive.comparison_tables` (the report's physics tables),
:mod:`~roadtex.archive.outputs` (reading outputs back) and :mod:`~roadtex.archive.job` (the job).
"""

from roadtex.archive.combined import combine, software_versions
from roadtex.archive.compute import compute_run
from roadtex.archive.job import ProcessSummary, process
from roadtex.archive.manifest import build_manifest, read_manifest
from roadtex.archive.options import ProcessingOptions
from roadtex.archive.outputs import read_profiles
from roadtex.archive.plan import GroupPilot, JobPlan, RunPlan
from roadtex.archive.reading import is_surface_run
from roadtex.archive.schemas import (
                                     BAND_SCHEMA,
                                     EDGE_EFFECT_SCHEMA,
                                     ERROR_SCHEMA,
                                     EXAMPLE_SCHEMA,
                                     MANIFEST_COLUMNS,
                                     METADATA_COLUMNS,
                                     NOISE_PREFIX,
                                     PROFILE_SCHEMA,
                                     RUN_SCHEMA,
                                     SEGMENT_SCHEMA,
                                     SURFACE_EXAMPLE_SCHEMA,
)
from roadtex.archive.store import file_sha256, remove_outputs
from roadtex.archive.surface_run import compute_surface_run
from roadtex.archive.worker import process_run
from roadtex.errors import ArchiveWriteError, ManifestError

__all__ = ["compute_run", "ProcessSummary", "combine", "process", "process_run", "read_profiles", "software_versions",
           "build_manifest", "read_manifest", "ProcessingOptions", "BAND_SCHEMA", "EDGE_EFFECT_SCHEMA", "ERROR_SCHEMA",
           "EXAMPLE_SCHEMA", "MANIFEST_COLUMNS", "METADATA_COLUMNS", "NOISE_PREFIX", "PROFILE_SCHEMA", "RUN_SCHEMA",
           "SEGMENT_SCHEMA", "SURFACE_EXAMPLE_SCHEMA", "compute_surface_run", "is_surface_run",
           "file_sha256", "remove_outputs", "ArchiveWriteError", "ManifestError", "JobPlan", "RunPlan", "GroupPilot"]
