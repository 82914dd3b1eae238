"""The job: every run of a manifest processed, resumable, and the combined tables written."""

from __future__ import annotations

import contextlib
import dataclasses
import importlib.util
import logging
import os
import platform
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Sequence

import numpy as np
import polars as pl

from roadtex._checks import positive_int, thread_count
from roadtex._core import __version__
from roadtex.archive.arrow_schema import table_options
from roadtex.archive.compute import RunFailure, compute_run, run_stage
from roadtex.archive.engines import Progress, process_dask, process_local
from roadtex.archive.manifest import read_manifest
from roadtex.archive.options import ProcessingOptions
from roadtex.archive.plan import JobPlan, group_key, plan_job
from roadtex.archive.schemas import (
    AREAL_SCHEMA,
    BAND_SCHEMA,
    EDGE_EFFECT_SCHEMA,
    ERROR_SCHEMA,
    EXAMPLE_SCHEMA,
    PENETRATION_SCHEMA,
    PILOT_SCHEMA,
    RUN_BAND_SCHEMA,
    RUN_RUN_SCHEMA,
    RUN_SCHEMA,
    SECTION_BAND_SCHEMA,
    SECTION_SCHEMA,
    SEGMENT_SCHEMA,
    SURFACE_ERROR_SCHEMA,
    SURFACE_EXAMPLE_SCHEMA,
    TABLES,
    VON_MEIER_SCHEMA,
    units,
)
from roadtex.archive.store import (
    STATUS_FILE,
    check_writable,
    checksums,
    damaged_outputs,
    file_sha256,
    file_size,
    job_lock,
    read_status,
    remove_stale_temporaries,
    run_fingerprint,
    write_atomically,
    write_error,
    write_json,
)
from roadtex.archive.surface_run import compute_surface_run, is_surface_run
from roadtex.comparisons.figures import edge_effect, example_comparisons
from roadtex.errors import (
    CoarseSamplingWarning,
    ErrorBudgetWarning,
    ImplausibleParameterWarning,
    ImplausibleTextureWarning,
    InvalidInputError,
    JobInterrupted,
    MissingDependencyError,
    ResultsNotFoundError,
)
from roadtex.profiles.plausibility import judged_once

log = logging.getLogger("roadtex.archive")
Engine = Literal["local", "dask"]
#: The tables the job makes from each run's example segment for the report (the seed's figures 2.1, 4.3).
COMPARISON_TABLES = {"von_meier": VON_MEIER_SCHEMA, "penetration": PENETRATION_SCHEMA}
#: The tables per section of road of each line run (:mod:`roadtex.archive.sections`).
SECTION_TABLES = {"sections": SECTION_SCHEMA, "section_bands": SECTION_BAND_SCHEMA}
#: Tables of some runs only (line runs: sections; surface runs: areal parameters), combined from those that have them.
SECTION_TABLES["areal"] = AREAL_SCHEMA
#: Units of ProcessingOptions' fields, recorded in parameters.json.
OPTION_UNITS = {"youngs_moduli": "Pa", "mean_pressure": "Pa", "segment_length": "m", "segment_overlap": "m",
                "dx": "m", "speed_kmh": "km/h", "tol": "1", "poisson": "1", "error_budget_db": "dB"}
OPTION_UNITS["section_length"] = "m"


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
    dx: float | None = None
    #: surface runs among ``runs`` (solved at their own spacings, not at ``dx``)
    surface_runs: int = 0

    def __str__(self) -> str:
        earlier = self.failed_on_record - self.failed
        record = (f" ({earlier} more failed in an earlier call and were not retried: see errors.parquet, "
                  "or process again with --retry-failed)") if earlier > 0 else ""
        line_runs = self.runs - self.surface_runs
        # no run done, no interval to state (the plan's fallback when no run could be read is no sampling of the road)
        done = self.processed + self.skipped > 0
        grid = f" at dx {self.dx * 1e3:.4g} mm" if self.dx is not None and line_runs and done else ""
        if self.surface_runs:
            grid += f"{',' if grid else ';'} {self.surface_runs} surface run(s) at their own spacings"
        length = f"{self.kilometres:.3f} km" if self.kilometres >= 1.0 else f"{self.kilometres * 1e3:.4g} m"
        return (f"{self.runs} runs: {self.processed} processed, {self.skipped} already done, "
                f"{self.failed} failed{record}; {length} of road{grid} in {self.seconds:.1f} s "
                f"-> {self.out_dir}")


def process_run(run: dict[str, Any], options: ProcessingOptions, out_dir: str | os.PathLike[str], *,
                threads: int | None = None, force: bool = False, retry_failed: bool = False) -> dict[str, Any]:
    """Processes one manifest row and writes its outputs atomically to ``out_dir/runs/<run_id>/``.

    ``options`` are the resolved ones (``dx`` set, see :class:`~roadtex.archive.plan.JobPlan`).
    Skips the work when the run's status already matches the options and the input file, unless
    ``force``, or ``retry_failed`` and the run failed.

    Returns:
        The run's status: ``state`` ("ok", "error" or "skipped"), fingerprints, ``kilometres`` and,
        on error, ``stage``, ``error_type`` and ``message``.

    Raises:
        ArchiveWriteError: the outputs could not be written.
    """
    run_dir = Path(out_dir) / "runs" / run["run_id"]
    options_fingerprint = options.fingerprint()
    try:
        input_sha256 = file_sha256(run["path"])
    except OSError as exc:
        input_sha256 = f"unreadable: {exc}"
    own_grids = [entry for entry in options.group_model_dx if entry[0] == group_key(run)]
    fingerprint = run_fingerprint(options_fingerprint, input_sha256, run, own_grids)
    previous = read_status(run_dir)
    if (not force and previous is not None and previous.get("fingerprint") == fingerprint
            and not (retry_failed and previous.get("state") == "error")):
        damaged = damaged_outputs(run_dir, previous)
        if not damaged:
            return {**previous, "skipped": True}
        # what the run wrote was changed or damaged since: computed again, never trusted
        log.warning("%s: %s do(es) not match the checksums recorded; recomputing the run",
                    run["run_id"], ", ".join(damaged))
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
        (run_dir / STATUS_FILE).unlink(missing_ok=True)  # from here until the new status lands, the run is not done
    except OSError as exc:
        raise write_error(exc.errno, f"cannot write to {run_dir}: {exc.strerror or exc}") from exc
    started = time.perf_counter()
    status: dict[str, Any] = {"run_id": run["run_id"], "path": run["path"], "fingerprint": fingerprint,
                              "options_fingerprint": options_fingerprint, "input_sha256": input_sha256}
    try:
        compute = compute_surface_run if is_surface_run(run) else compute_run
        # compute_run judges a line run's heights itself and refuses an implausible run: the reader,
        # contact model, spectra and comparisons it calls on them do not judge them again
        with judged_once() if compute is compute_run else contextlib.nullcontext():
            tables = compute(run, options, threads=threads)
            if tables.get("example") is not None:
                tables.update(run_stage("solve", lambda: comparison_tables(tables["example"], options.mean_pressure)))
    except RunFailure as failure:
        # every recorded message names the file, whichever stage failed (the readers' do already)
        message, name = str(failure.cause), Path(run["path"]).name
        status.update(state="error", stage=failure.stage, error_type=type(failure.cause).__name__,
                      message=message if name in message else f"{name}: {message}", kilometres=0.0)
    else:
        written = []
        for name, table in tables.items():
            if not isinstance(table, pl.DataFrame):   # None, or a note for the status
                continue
            write_atomically(run_dir / f"{name}.parquet", lambda p, t=table: t.write_parquet(p, statistics=True))
            written.append(f"{name}.parquet")
        status.update(state="ok", kilometres=float(tables["run"]["length"][0]) / 1e3,
                      seconds=time.perf_counter() - started, checksums=checksums(run_dir, written))
        # a surface run whose areal pilot could not run; a run processed although implausible
        # (allow_implausible), or sampled more coarsely than texture (the job warns after the runs)
        for note in ("pilot_note", *PLAUSIBILITY_NOTES):
            if tables.get(note) is not None:
                status[note] = tables[note]
    for stale in ("example", "segments", "bands", "run", "profiles", "surface_example", "level_errors",
                  *COMPARISON_TABLES, *SECTION_TABLES):
        if status["state"] != "ok" or tables.get(stale) is None:  # failed, or not made this time
            (run_dir / f"{stale}.parquet").unlink(missing_ok=True)
    write_json(run_dir / STATUS_FILE, status)
    return {**status, "skipped": False}


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
        engine: "local" (two runs at a time on this machine, segments in parallel on ``threads``
            Rust threads) or "dask" (runs distributed over Dask workers).
        scheduler: Dask scheduler address; None starts a local cluster of ``workers`` processes.
        workers: worker processes of the local Dask cluster.
        threads: Rust threads per solve batch (None: all cores; with the local Dask cluster the
            default is one per worker).
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
    resolved: ProcessingOptions | None = None   # until the plan is made
    try:
        # the plan (error budget pilot, sampling interval) is for line runs; surface runs use its tol
        # and their own spacings
        with warnings.catch_warnings():
            if options.allow_implausible:   # asked for: the pilot's solves do not warn either
                warnings.simplefilter("ignore", ImplausibleParameterWarning)
            plan, study = plan_job([run for run in runs if not is_surface_run(run)], options, threads=threads)
        resolved = plan.resolved(options)
        progress = Progress(len(runs), sum(sizes), quiet)
        flags = {"force": force, "retry_failed": retry_failed}
        try:
            with warnings.catch_warnings():
                if options.allow_implausible:   # asked for: the runs' solvers do not warn again, run after run
                    warnings.simplefilter("ignore", ImplausibleParameterWarning)
                if engine == "local":
                    finished = process_local(process_run, runs, sizes, resolved, out, threads, flags)
                else:
                    finished = process_dask(process_run, runs, sizes, resolved, out, scheduler, workers, threads,
                                            flags)
                for status, size in finished:
                    statuses[status["run_id"]] = status
                    progress.update(status, size)
        finally:
            progress.close()
        tables = combine(table, out, resolved, plan=plan, requested=options, study=study)
    except KeyboardInterrupt:
        # the runs in flight have finished writing by now (the engines wait for them): what is on
        # disk is complete, and a rerun resumes from it
        remove_stale_temporaries(out)
        raise JobInterrupted(runs_done(out, runs, resolved, statuses), len(runs)) from None
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
        failed_on_record=sum(1 for s in statuses.values() if s["state"] == "error"), dx=plan.dx,
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


def combine(manifest: pl.DataFrame, out_dir: str | os.PathLike[str], options: ProcessingOptions, *,
            plan: JobPlan | None = None, requested: ProcessingOptions | None = None,
            study: pl.DataFrame | None = None) -> dict[str, Path]:
    """Concatenates the per-run tables of the runs in ``manifest`` (in its order) into the combined tables.

    ``options`` are the resolved options the runs were solved with; ``requested`` and ``plan``
    (what the caller asked for, and how the job chose its sampling) go into parameters.json.

    Only runs whose status is current for ``options`` count; stale folders are ignored. The
    tables are streamed from the per-run files to the combined file (polars' streaming sink), so
    memory does not grow with the archive.
    """
    out = Path(out_dir)
    options_fingerprint = options.fingerprint()
    parts: dict[str, list[Path]] = {"segments": [], "bands": [], "runs": [], "examples": [], "surface_examples": [],
                                    **{name: [] for name in COMPARISON_TABLES}, **{name: [] for name in SECTION_TABLES}}
    errors: list[dict[str, Any]] = []
    surface_error_files: list[Path] = []
    pilot_notes: dict[str, str] = {}
    for run in manifest.iter_rows(named=True):
        run_dir = out / "runs" / run["run_id"]
        status = read_status(run_dir)
        if status is None or status.get("options_fingerprint") != options_fingerprint:
            continue
        if status["state"] == "error":
            errors.append({name: status.get(name) for name in ERROR_SCHEMA})
            continue
        parts["segments"].append(run_dir / "segments.parquet")
        parts["bands"].append(run_dir / "bands.parquet")
        parts["runs"].append(run_dir / "run.parquet")
        if (run_dir / "example.parquet").exists():
            parts["examples"].append(run_dir / "example.parquet")
            parts["von_meier"].append(run_dir / "von_meier.parquet")
            parts["penetration"].append(run_dir / "penetration.parquet")
            if not all((run_dir / f"{name}.parquet").exists() for name in COMPARISON_TABLES):
                # a run processed by a roadtex before these tables: made from its own example solves
                comparisons = comparison_tables(pl.read_parquet(run_dir / "example.parquet"), options.mean_pressure)
                for name, frame in comparisons.items():
                    write_atomically(run_dir / f"{name}.parquet", lambda p, t=frame: t.write_parquet(p, statistics=True))
        for name in SECTION_TABLES:   # line runs' sections, surface runs' areal parameters
            if (run_dir / f"{name}.parquet").exists():
                parts[name].append(run_dir / f"{name}.parquet")
        if (run_dir / "surface_example.parquet").exists():
            parts["surface_examples"].append(run_dir / "surface_example.parquet")
        if (run_dir / "level_errors.parquet").exists():
            surface_error_files.append(run_dir / "level_errors.parquet")
        if status.get("pilot_note"):
            pilot_notes[run["run_id"]] = status["pilot_note"]
    schemas = {"segments": SEGMENT_SCHEMA, "bands": RUN_BAND_SCHEMA, "runs": RUN_RUN_SCHEMA, "examples": EXAMPLE_SCHEMA,
               "surface_examples": SURFACE_EXAMPLE_SCHEMA, **COMPARISON_TABLES, **SECTION_TABLES}
    combined = {**schemas, "bands": BAND_SCHEMA, "runs": RUN_SCHEMA}
    estimates = run_estimates(manifest, parts["runs"], plan)
    # the plan (its pilot, error estimates and speed-up) covers line runs only; surface runs have
    # their own areal pilot's
    surface_ids = [run["run_id"] for run in manifest.iter_rows(named=True) if is_surface_run(run)]
    own = surface_estimates(surface_error_files, options.error_budget_db)
    written = {}
    for name, files in parts.items():
        path = out / f"{name}.parquet"
        metadata = table_options(TABLES[name])
        if files:
            query = with_plan(pl.scan_parquet(files, schema=schemas[name]), name, plan, estimates, surface_ids,
                              own).select(
                [pl.col(c).cast(t) for c, t in combined[name].items()])
            write_atomically(path, lambda p, q=query, m=metadata: q.sink_parquet(p, statistics=True, **m))
        else:
            empty = pl.DataFrame(schema=combined[name])
            write_atomically(path, lambda p, t=empty, m=metadata: t.write_parquet(p, statistics=True, **m))
        written[name] = path
    edge = edge_effect_table(options)
    write_atomically(out / "edge_effect.parquet",
                     lambda p: edge.select(list(TABLES["edge_effect"])).write_parquet(p, **table_options(TABLES["edge_effect"])))
    written["edge_effect"] = out / "edge_effect.parquet"
    pilot = (study.select([pl.col(c).cast(t) if c in study.columns else pl.lit(None, dtype=t).alias(c)
                           for c, t in PILOT_SCHEMA.items()])
             if study is not None and study.height else pl.DataFrame(schema=PILOT_SCHEMA))
    write_atomically(out / "pilot.parquet", lambda p: pilot.write_parquet(p, **table_options(TABLES["pilot"])))
    written["pilot"] = out / "pilot.parquet"
    error_table = pl.DataFrame(errors, schema=ERROR_SCHEMA)
    write_atomically(out / "errors.parquet", lambda p: error_table.write_parquet(p, **table_options(TABLES["errors"])))
    written["errors"] = out / "errors.parquet"
    write_json(out / "parameters.json", {
        "options": dataclasses.asdict(options), "options_fingerprint": options_fingerprint,
        "requested_options": dataclasses.asdict(requested or options),
        "plan": plan.summary() if plan is not None else None,
        # surface runs whose areal pilot could not run (their levels have no error estimate), and why
        "surface_pilot_notes": pilot_notes,
        "units": {"options": OPTION_UNITS, **{name: units(columns) for name, columns in TABLES.items()}},
        "versions": software_versions(), "runs": manifest.height,
        # verified by the report before it draws anything (a table damaged since is refused)
        "checksums": checksums(out, [path.name for path in written.values()]),
    })
    written["parameters"] = out / "parameters.json"
    if options.keep_profiles:
        written["profiles"] = out / "runs"
    return written


def runs_done(out: Path, runs: list[dict[str, Any]], resolved: ProcessingOptions | None,
              statuses: dict[str, dict[str, Any]]) -> int:
    """The runs whose results are complete on disk for this job after a Ctrl-C: those whose status
    file holds the job's options (the runs in flight at the Ctrl-C finish after the job stopped
    counting them: they count too); before the plan, those the job had counted."""
    if resolved is None:
        return len(statuses)
    fingerprint = resolved.fingerprint()
    return sum(1 for run in runs
               if (read_status(out / "runs" / run["run_id"]) or {}).get("options_fingerprint") == fingerprint)


def run_estimates(manifest: pl.DataFrame, run_files: list[Path], plan: JobPlan | None) -> tuple[pl.DataFrame, pl.DataFrame]:
    """Each line run's error estimates from its own pilot group (device, pavement, file sampling
    interval), or the largest of any group when no pilot covered its group: per (run, band)
    ``level_error_db`` and per run ``worst_level_error_db`` and ``within_budget``. Surface runs
    have none: the pilot is of line runs, and a surface run is solved at its own spacings."""
    band_rows: list[tuple[str, int, float, float | None, bool | None]] = []
    run_rows: list[tuple[str, float | None, bool | None]] = []
    if plan is not None and plan.budget_db is not None and run_files:
        file_dx = dict(pl.scan_parquet(run_files, schema=RUN_RUN_SCHEMA).select("run_id", "file_dx").collect().iter_rows())
        for run in manifest.iter_rows(named=True):
            if run["run_id"] not in file_dx or is_surface_run(run):
                continue
            group = plan.group_of(run, file_dx[run["run_id"]])
            errors = plan.band_error_db if group is None else group.band_error_db
            spread = plan.interpolant_spread_db if group is None else group.interpolant_spread_db
            band_rows += [(run["run_id"], band, error, spread.get(band),
                           None if band not in spread else bool(spread[band] > plan.budget_db))
                          for band, error in errors.items() if np.isfinite(error)]
            run_rows.append((run["run_id"], plan.worst_error_db if group is None else group.worst_error_db,
                             plan.within_budget if group is None else group.within_budget))
    bands = pl.DataFrame(band_rows, schema={"run_id": pl.String, "band": pl.Int64, "level_error_db": pl.Float64,
                                            "interpolant_spread_db": pl.Float64, "sampling_limited": pl.Boolean},
                         orient="row")
    runs = pl.DataFrame(run_rows, schema={"run_id": pl.String, "worst_level_error_db": pl.Float64, "within_budget": pl.Boolean},
                        orient="row")
    return bands, runs


def surface_estimates(files: list[Path], budget_db: float | None) -> tuple[pl.DataFrame, pl.DataFrame]:
    """The surface runs' own error estimates (their ``level_errors.parquet``, from the areal pilot):
    per (run, model, band) ``surface_error_db``, and per run ``surface_worst_db`` (the largest in
    the budget bands, both models), ``surface_within`` and ``surface_speedup``."""
    bands_schema = {"run_id": pl.String, "model": pl.String, "band": pl.Int64, "surface_error_db": pl.Float64}
    runs_schema = {"run_id": pl.String, "surface_worst_db": pl.Float64, "surface_within": pl.Boolean,
                   "surface_speedup": pl.Float64}
    if not files or budget_db is None:
        return pl.DataFrame(schema=bands_schema), pl.DataFrame(schema=runs_schema)
    table = pl.read_parquet(files, schema=SURFACE_ERROR_SCHEMA)
    bands = table.select("run_id", "model", "band", pl.col("level_error_db").alias("surface_error_db"))
    runs = table.group_by("run_id", maintain_order=True).agg(
        pl.col("level_error_db").filter(pl.col("in_budget")).max().alias("surface_worst_db"),   # null: no budget band
        pl.col("speedup").first().alias("surface_speedup"))
    runs = runs.with_columns((pl.col("surface_worst_db") <= budget_db).alias("surface_within"))
    return bands.cast(bands_schema), runs.select(list(runs_schema)).cast(runs_schema)  # type: ignore[arg-type]


def with_plan(query: pl.LazyFrame, name: str, plan: JobPlan | None,
              estimates: tuple[pl.DataFrame, pl.DataFrame], surface_ids: Sequence[str] = (),
              surface_own: tuple[pl.DataFrame, pl.DataFrame] | None = None) -> pl.LazyFrame:
    """The plan's columns added to a combined table: each band row's error estimate, each run's
    worst error and budget verdict (``estimates``, from :func:`run_estimates`), the speed-up and
    time saved (null where the plan has none). The rows of the surface runs ``surface_ids``,
    which the plan does not cover, get their own areal pilot's (``surface_own``, from
    :func:`surface_estimates`; null where there is none)."""
    band_errors, run_verdicts = estimates
    own_bands, own_runs = surface_own if surface_own is not None else surface_estimates([], None)
    surface = pl.col("run_id").is_in(pl.Series(list(surface_ids), dtype=pl.String).implode())
    if name == "bands":
        joined = (query.join(band_errors.lazy(), on=["run_id", "band"], how="left", maintain_order="left")
                  .join(own_bands.lazy(), on=["run_id", "model", "band"], how="left", maintain_order="left"))
        # the line pilot measures the line model of line runs only
        line_only = surface | (pl.col("model") == "areal")
        return joined.with_columns(pl.when(surface).then(pl.col("surface_error_db"))
                                   .when(pl.col("model") == "areal").then(None)
                                   .otherwise(pl.col("level_error_db")).alias("level_error_db"),
                                   *[pl.when(line_only).then(None).otherwise(pl.col(c)).alias(c)
                                     for c in ("interpolant_spread_db", "sampling_limited")])
    if name == "runs":
        # Only deterministic numbers go in the tables (a re-run, a resumed run and the Dask engine must
        # give the same bits): the saving as a share of the solver work; measured seconds are in
        # parameters.json and pilot.parquet.
        speedup = None if plan is None else plan.speedup
        joined = (query.join(run_verdicts.lazy(), on="run_id", how="left", maintain_order="left")
                  .join(own_runs.lazy(), on="run_id", how="left", maintain_order="left"))
        ratio = pl.when(surface).then(pl.col("surface_speedup")).otherwise(pl.lit(speedup, dtype=pl.Float64))
        return joined.with_columns(
            pl.when(surface).then(pl.col("surface_worst_db")).otherwise(pl.col("worst_level_error_db"))
            .alias("worst_level_error_db"),
            pl.when(surface).then(pl.col("surface_within")).otherwise(pl.col("within_budget")).alias("within_budget"),
            ratio.cast(pl.Float64).alias("speedup"),
            (1.0 - 1.0 / ratio).cast(pl.Float64).alias("time_saved_fraction"))
    return query


def comparison_tables(example: pl.DataFrame, mean_pressure: float) -> dict[str, pl.DataFrame]:
    """The seed's model comparisons on a run's example segment (``example``, EXAMPLE_SCHEMA: the
    job's own solves at every modulus, at ``mean_pressure`` Pa): its von Meier envelopes and valley
    penetration table (:func:`roadtex.comparisons.figures.example_comparisons`), what the report's
    figures 2.1 and 4.3 draw without computing anything."""
    rows = example.sort("youngs_modulus", "position")
    moduli = rows["youngs_modulus"].unique(maintain_order=True).to_list()
    first = rows.filter(pl.col("youngs_modulus") == moduli[0])
    envelopes = {float(e): rows.filter(pl.col("youngs_modulus") == e)["envelope"].to_numpy() for e in moduli}
    envelope_table, penetration = example_comparisons(first["height"].to_numpy(), float(first["dx"][0]), envelopes,
                                                      mean_pressure=mean_pressure)
    keys = [pl.lit(first["run_id"][0]).alias("run_id"), pl.lit(int(first["segment"][0])).alias("segment")]
    return {name: table.with_columns(keys).select([pl.col(c).cast(t) for c, t in COMPARISON_TABLES[name].items()])
            for name, table in (("von_meier", envelope_table), ("penetration", penetration))}


def software_versions() -> dict[str, str]:
    """Versions of roadtex and what it computes with (recorded in parameters.json)."""
    return {"roadtex": __version__, "python": platform.python_version(), "numpy": np.__version__,
            "polars": pl.__version__, "platform": platform.platform()}


def read_profiles(out_dir: str | os.PathLike[str], *, run_id: str | None = None, start: float | None = None,
                  end: float | None = None, youngs_modulus: float | None = None) -> pl.DataFrame:
    """Reads stitched enveloped profiles and pressures back, by run and position range (m).

    Needs a job run with ``keep_profiles=True``; columns as :data:`PROFILE_SCHEMA`.
    """
    root = Path(out_dir) / "runs"
    pattern = str(root / (run_id if run_id is not None else "*") / "profiles.parquet")
    if not any(root.glob(f"{run_id if run_id is not None else '*'}/profiles.parquet")):
        raise ResultsNotFoundError(f"no profiles under {root}{' for run ' + run_id if run_id else ''}; "
                                "process with keep_profiles=True (--keep-profiles)")
    query = pl.scan_parquet(pattern)
    if start is not None:
        query = query.filter(pl.col("position") >= start)
    if end is not None:
        query = query.filter(pl.col("position") < end)
    if youngs_modulus is not None:
        query = query.filter(pl.col("youngs_modulus") == float(youngs_modulus))
    return query.collect()


def edge_effect_table(options: ProcessingOptions, points: int = 1024, length: float = 0.1) -> pl.DataFrame:
    """The seed's figure 3.1 for the job's load and middle modulus: a flat profile of ``length`` (m),
    finite against periodic model (EDGE_EFFECT_SCHEMA), solved here so the report only reads."""
    moduli = sorted(options.youngs_moduli)
    modulus = moduli[len(moduli) // 2]
    table = edge_effect(points=points, length=length, youngs_modulus=modulus, mean_pressure=options.mean_pressure,
                        poisson=options.poisson, tol=1e-10)
    return table.with_columns(pl.lit(modulus).alias("youngs_modulus"),
                              pl.lit(options.mean_pressure).alias("mean_pressure")).cast(EDGE_EFFECT_SCHEMA)  # type: ignore[arg-type]
