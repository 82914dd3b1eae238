"""The job: every run of a manifest planned, processed (resumable) and combined into tables.

The stops a parameter makes, from the command line to a solve: ``roadtex process`` (:mod:`roadtex.cli`)
builds :class:`~roadtex.archive.options.ProcessingOptions` (what the user chose, checked once,
frozen); :func:`process` makes the job's :class:`~roadtex.archive.plan.JobPlan` from them
(:func:`roadtex.archive.planning.plan_job`: pilots, or those kept in the output folder); an engine
(:mod:`roadtex.archive.engines`) hands the plan and each manifest row to
:func:`roadtex.archive.worker.process_run`, which reads the run and takes its entry
(:meth:`~roadtex.archive.plan.JobPlan.line_entry`) for :func:`roadtex.archive.compute.compute_run`,
where the solve uses the entry's interval, model grid and tolerance and the options' moduli and
pressure; :func:`roadtex.archive.combined.combine` joins the plan's estimates into the tables.
"""

from __future__ import annotations

import importlib.util
import os
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Sequence

import polars as pl

from roadtex._checks import positive_int, thread_count
from roadtex.archive.combined import combine
from roadtex.archive.engines import Progress, process_dask, process_local
from roadtex.archive.manifest import read_manifest
from roadtex.archive.options import ProcessingOptions
from roadtex.archive.planning import plan_job
from roadtex.archive.reading import is_surface_run
from roadtex.archive.store import check_writable, file_size, job_lock, read_status, remove_stale_temporaries
from roadtex.archive.worker import process_run
from roadtex.errors import (
    CoarseSamplingWarning,
    ErrorBudgetWarning,
    ImplausibleParameterWarning,
    ImplausibleTextureWarning,
    InvalidInputError,
    JobInterrupted,
    MissingDependencyError,
)

Engine = Literal["local", "dask"]


@dataclass(frozen=True)
class ProcessSummary:
    """What a :func:`process` call did."""

    out_dir: Path
    runs: int
    processed: int
    skipped: int
    failed: int
    kilometres: float
    seconds: float
    tables: dict[str, Path] = field(default_factory=dict)
    #: runs whose latest attempt failed, this call or an earlier one (errors.parquet lists them)
    failed_on_record: int = 0
    #: the intervals (m) the line runs done were solved at, each its own (or coarser where its pilot chose)
    intervals: tuple[float, ...] = ()
    #: surface runs among ``runs`` (solved at their own spacings)
    surface_runs: int = 0

    def __str__(self) -> str:
        earlier = self.failed_on_record - self.failed
        record = (f" ({earlier} more failed in an earlier call and were not retried: see errors.parquet, "
                  "or process again with --retry-failed)") if earlier > 0 else ""
        # each line run at its own interval: one named when they share it, else their range
        low, high = (min(self.intervals), max(self.intervals)) if self.intervals else (None, None)
        grid = ("" if low is None or high is None else f" at dx {low * 1e3:.4g} mm" if high <= low * (1 + 1e-9)
                else f" at their own intervals, dx {low * 1e3:.4g} to {high * 1e3:.4g} mm")
        if self.surface_runs:
            grid += f"{',' if grid else ';'} {self.surface_runs} surface run(s) at their own spacings"
        length = f"{self.kilometres:.3f} km" if self.kilometres >= 1.0 else f"{self.kilometres * 1e3:.4g} m"
        return (f"{self.runs} runs: {self.processed} processed, {self.skipped} already done, "
                f"{self.failed} failed{record}; {length} of road{grid} in {self.seconds:.1f} s "
                f"-> {self.out_dir}")


# --------------------------------------------------------------------------------------------
# The job
# --------------------------------------------------------------------------------------------

def process(manifest: str | os.PathLike[str] | pl.DataFrame, out_dir: str | os.PathLike[str],
            options: ProcessingOptions | None = None, *, engine: Engine = "local", scheduler: str | None = None,
            workers: int = 2, threads: int | None = None, quiet: bool = False, force: bool = False,
            retry_failed: bool = False, extra_columns: Sequence[str] = ()) -> ProcessSummary:
    """Processes every run of a manifest and writes the combined tables to ``out_dir``.

    Args:
        manifest: manifest file (CSV/Parquet) or DataFrame, see :func:`read_manifest`.
        out_dir: output folder (created).
        options: what to compute; default :class:`ProcessingOptions()`.
        engine: "local" (a few runs at a time on this machine, segments in parallel on ``threads``
            Rust threads: :func:`roadtex.archive.engines.local_schedule`) or "dask" (runs
            distributed over Dask workers).
        scheduler: Dask scheduler address; None starts a local cluster of ``workers`` processes.
        workers: worker processes of the local Dask cluster.
        threads: Rust threads per solve batch (None: the job shares the cores between its runs in
            flight, one thread each on a long job and every core for its last runs; with the local
            Dask cluster the default is one per worker).
        quiet: no progress bar; one log line per run instead (logger ``roadtex.archive``).
        force: recompute runs even when their status is current.
        retry_failed: process again the runs whose last attempt failed (by default a failure stays
            on record, is counted in the summary and listed in errors.parquet until retried).

    Returns:
        A :class:`ProcessSummary`.

    Raises:
        ManifestError: a bad manifest (before any work starts).
        ArchiveWriteError: the output folder cannot be written.
        JobInterrupted: Ctrl-C (a KeyboardInterrupt): the runs in flight finish, temporary files
            are removed, and the same call again resumes.
    """
    options = options or ProcessingOptions()
    threads = thread_count(threads)   # job-wide options: refused before any work, not by every run
    if engine not in ("local", "dask"):
        raise InvalidInputError(f"engine must be 'local' or 'dask', got {engine!r}")
    if engine == "dask" and importlib.util.find_spec("distributed") is None:
        raise MissingDependencyError("engine='dask' needs dask.distributed: pip install 'roadtex[dask]'")
    if engine == "dask" and scheduler is None:
        positive_int(workers, "workers")   # a local cluster of 0 workers waits forever for one
    table = read_manifest(manifest, extra_columns=extra_columns)
    out = Path(out_dir)
    check_writable(out)
    with job_lock(out):   # one job a folder: a second would remove the first one's files mid-write
        return process_locked(table, out, options, engine=engine, scheduler=scheduler, workers=workers,
                              threads=threads, quiet=quiet, force=force, retry_failed=retry_failed)


def process_locked(table: pl.DataFrame, out: Path, options: ProcessingOptions, *, engine: Engine,
                   scheduler: str | None, workers: int, threads: int | None, quiet: bool, force: bool,
                   retry_failed: bool) -> ProcessSummary:
    """:func:`process` once its manifest and options are checked and the output folder's lock is held."""
    remove_stale_temporaries(out)
    runs = table.to_dicts()
    sizes = [file_size(run["path"]) for run in runs]
    started = time.perf_counter()
    statuses: dict[str, dict[str, Any]] = {}
    planned = False
    try:
        # the line runs' pilots (surface runs have their own, per run), or those the folder kept
        with warnings.catch_warnings():
            if options.allow_implausible:   # asked for: the pilot's solves do not warn either
                warnings.simplefilter("ignore", ImplausibleParameterWarning)
            plan, study = plan_job([run for run in runs if not is_surface_run(run)], options, threads=threads, out=out,
                                   reuse=not force)
        planned = True
        progress = Progress(len(runs), sum(sizes), quiet)
        flags = {"force": force, "retry_failed": retry_failed}
        try:
            with warnings.catch_warnings():
                if options.allow_implausible:   # asked for: the runs' solvers do not warn again, run after run
                    warnings.simplefilter("ignore", ImplausibleParameterWarning)
                if engine == "local":
                    finished = process_local(process_run, runs, sizes, plan, out, threads, flags)
                else:
                    finished = process_dask(process_run, runs, sizes, plan, out, scheduler, workers, threads,
                                            flags)
                for status, size in finished:
                    statuses[status["run_id"]] = status
                    progress.update(status, size)
        finally:
            progress.close()
        tables = combine(table, out, plan, study=study, keep=not force)
    except KeyboardInterrupt:
        # the runs in flight have finished writing by now (the engines wait for them): what is on
        # disk is complete, and a rerun resumes from it
        remove_stale_temporaries(out)
        raise JobInterrupted(runs_done(out, runs, options if planned else None, statuses), len(runs)) from None
    warn_surfaces_over_budget(tables["runs"], [run["run_id"] for run in runs if is_surface_run(run)],
                              options.error_budget_db)
    warn_plausibility_notes([statuses[run["run_id"]] for run in runs if run["run_id"] in statuses])
    counts = {state: sum(1 for s in statuses.values() if s["state"] == state and not s["skipped"])
              for state in ("ok", "error")}
    return ProcessSummary(
        out_dir=out, runs=len(runs), processed=counts["ok"], failed=counts["error"],
        skipped=sum(1 for s in statuses.values() if s["skipped"]),
        kilometres=sum(float(s.get("kilometres", 0.0)) for s in statuses.values() if not s["skipped"]),
        seconds=time.perf_counter() - started, tables=tables,
        failed_on_record=sum(1 for s in statuses.values() if s["state"] == "error"),
        intervals=tuple(sorted({float(s["plan"]["data_dx"]) for s in statuses.values()
                                if s["state"] == "ok" and (s.get("plan") or {}).get("data_dx") is not None})),
        surface_runs=sum(1 for run in runs if is_surface_run(run)))


#: The notes of a run's status that the job warns with after the runs, and their warnings.
PLAUSIBILITY_NOTES = {"implausible_note": ImplausibleTextureWarning, "sampling_note": CoarseSamplingWarning}
#: Runs whose notes of one kind are warned one by one; more are counted in one warning.
NOTES_WARNED = 5


def warn_plausibility_notes(statuses: list[dict[str, Any]]) -> None:
    """The notes (:data:`PLAUSIBILITY_NOTES`) that runs done this call or before (their status,
    processed with the same options) carry, as warnings: each run's own (it names the file), up to
    :data:`NOTES_WARNED` of a kind, then one naming how many more runs have one (their
    status.json files hold theirs). Warned here, in the caller's thread, after the runs: a run's
    own thread (or Dask worker) would print it amid the progress bar, or not at all."""
    for key, category in PLAUSIBILITY_NOTES.items():
        noted = [s for s in statuses if s.get("state") == "ok" and s.get(key)]
        for status in noted[:NOTES_WARNED]:
            warnings.warn(status[key], category, stacklevel=3)
        if len(noted) > NOTES_WARNED:
            rest = noted[NOTES_WARNED:]
            warnings.warn(f"{len(rest)} more run(s) with the same kind of note ({category.__name__}): "
                          f"{', '.join(str(s['run_id']) for s in rest[:5])}{' ...' if len(rest) > 5 else ''} "
                          "(runs/<run_id>/status.json holds each one's)", category, stacklevel=3)


def warn_surfaces_over_budget(runs_path: Path, surface_ids: list[str], budget_db: float | None) -> None:
    """One ErrorBudgetWarning naming the surface runs whose own pilot's estimate misses the budget
    (the line runs' plan warns for its groups)."""
    if budget_db is None or not surface_ids:
        return
    missed = (pl.read_parquet(runs_path).filter(pl.col("run_id").is_in(surface_ids) & (pl.col("within_budget").not_()))
              .select("run_id", "worst_level_error_db"))
    if missed.height:
        worst = ", ".join(f"{rid}: {err:.3g} dB" for rid, err in missed.head(5).iter_rows())
        more = f" and {missed.height - 5} more" if missed.height > 5 else ""
        warnings.warn(f"the error budget of {budget_db:g} dB cannot be met at the sampling of {missed.height} surface "
                      f"run(s) ({worst}{more}); each states its error per band (bands.parquet level_error_db)",
                      ErrorBudgetWarning, stacklevel=3)


def runs_done(out: Path, runs: list[dict[str, Any]], options: ProcessingOptions | None,
              statuses: dict[str, dict[str, Any]]) -> int:
    """The runs whose results are complete on disk for this job after a Ctrl-C: those whose status
    file holds the job's options (the runs in flight at the Ctrl-C finish after the job stopped
    counting them: they count too); before the plan, those the job had counted."""
    if options is None:
        return len(statuses)
    fingerprint = options.fingerprint()
    return sum(1 for run in runs
               if (read_status(out / "runs" / run["run_id"]) or {}).get("options_fingerprint") == fingerprint)


