"""One run of the job on a worker: whether it is already done, and if not its computation and its files.

A run is done when its folder's ``status.json`` holds the fingerprint of what its results depend
on (:func:`roadtex.archive.store.run_fingerprint`: the user's options, its file, its manifest row
and its plan entry) and its files still match the checksums recorded there. The plan entry of a
line run depends on its file's interval, which the status records: a rerun with nothing new
decides from the status alone, without reading the file (only hashing it).
"""

from __future__ import annotations

import contextlib
import logging
import os
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

import polars as pl

from roadtex.archive.comparison_tables import comparison_tables
from roadtex.archive.compute import RunFailure, compute_run, run_stage
from roadtex.archive.plan import JobPlan, RunPlan
from roadtex.archive.reading import is_surface_run, reader_options, surface_reader_options
from roadtex.archive.store import (
    STATUS_FILE,
    checksums,
    damaged_outputs,
    file_sha256,
    read_status,
    run_fingerprint,
    write_atomically,
    write_error,
    write_json,
)
from roadtex.archive.surface_run import compute_surface_run
from roadtex.profiles.plausibility import judged_once

log = logging.getLogger("roadtex.archive")

#: The notes of a run's status that the job warns with after the runs (see roadtex.archive.job).
STATUS_NOTES = ("pilot_note", "implausible_note", "sampling_note")
#: Every table a run may write (a table not made this time is removed, so no stale one is combined).
RUN_TABLES = ("example", "segments", "bands", "run", "profiles", "surface_example", "level_errors",
              "von_meier", "penetration", "sections", "section_bands", "areal")


def planned_entry(plan: JobPlan, run: dict[str, Any], file_dx: float | None) -> RunPlan | None:
    """A run's plan entry: a surface run's, or a line run's for its file's interval ``file_dx`` (m;
    None when the file was never read: the entry is not known)."""
    if is_surface_run(run):
        return plan.surface_entry()
    return None if file_dx is None else plan.line_entry(run, float(file_dx))


def fingerprint_of(plan: JobPlan, run: dict[str, Any], input_sha256: str, entry: RunPlan | None) -> str:
    options = plan.options
    reading = surface_reader_options(run, options) if is_surface_run(run) else reader_options(run, options)
    return run_fingerprint(options.fingerprint(), input_sha256, run, reading,
                           None if entry is None else entry.solved_as())


def process_run(run: dict[str, Any], plan: JobPlan, out_dir: str | os.PathLike[str], *,
                threads: int | None = None, force: bool = False, retry_failed: bool = False) -> dict[str, Any]:
    """Processes one manifest row as ``plan`` says and writes its outputs atomically to
    ``out_dir/runs/<run_id>/``.

    Skips the work when the run's status already holds its fingerprint and its files are intact,
    unless ``force``, or ``retry_failed`` and the run failed.

    Returns:
        The run's status: ``state`` ("ok" or "error"), ``skipped``, fingerprints, ``file_dx``, its
        plan entry (``plan``), ``kilometres`` and, on error, ``stage``, ``error_type`` and ``message``.

    Raises:
        ArchiveWriteError: the outputs could not be written.
    """
    run_dir = Path(out_dir) / "runs" / run["run_id"]
    try:
        input_sha256 = file_sha256(run["path"])
    except OSError as exc:
        input_sha256 = f"unreadable: {exc}"
    previous = read_status(run_dir)
    if not force and previous is not None and not (retry_failed and previous.get("state") == "error"):
        entry = planned_entry(plan, run, previous.get("file_dx"))
        if previous.get("fingerprint") == fingerprint_of(plan, run, input_sha256, entry):
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
    status: dict[str, Any] = {"run_id": run["run_id"], "path": run["path"], "input_sha256": input_sha256,
                              "options_fingerprint": plan.options.fingerprint(), "file_dx": None, "plan": None}
    tables: dict[str, Any] = {}
    try:
        surface = is_surface_run(run)
        # compute_run judges a line run's heights itself and refuses an implausible run: the reader,
        # contact model, spectra and comparisons it calls on them do not judge them again
        with contextlib.nullcontext() if surface else judged_once():
            tables = (compute_surface_run if surface else compute_run)(run, plan, threads=threads)
            if tables.get("example") is not None:
                tables.update(run_stage("solve", lambda: comparison_tables(tables["example"],
                                                                           plan.options.mean_pressure)))
    except RunFailure as failure:
        # every recorded message names the file, whichever stage failed (the readers' do already)
        message, name = str(failure.cause), Path(run["path"]).name
        status.update(state="error", stage=failure.stage, error_type=type(failure.cause).__name__,
                      message=message if name in message else f"{name}: {message}", kilometres=0.0)
        entry = planned_entry(plan, run, None)   # a line run's is not known: its failure stands until retried
    else:
        entry = tables["plan_entry"]
        written = []
        for name, table in tables.items():
            if isinstance(table, pl.DataFrame):   # None, the entry, or a note for the status otherwise
                write_atomically(run_dir / f"{name}.parquet", lambda p, t=table: t.write_parquet(p, statistics=True))
                written.append(f"{name}.parquet")
        status.update(state="ok", kilometres=float(tables["run"]["length"][0]) / 1e3,
                      seconds=time.perf_counter() - started, checksums=checksums(run_dir, written),
                      file_dx=float(tables["run"]["file_dx"][0]), plan=asdict(entry))
        for note in STATUS_NOTES:   # warned by the job after the runs, in its own thread
            if tables.get(note) is not None:
                status[note] = tables[note]
    status["fingerprint"] = fingerprint_of(plan, run, input_sha256, entry)
    for stale in RUN_TABLES:
        if status["state"] != "ok" or not isinstance(tables.get(stale), pl.DataFrame):
            (run_dir / f"{stale}.parquet").unlink(missing_ok=True)
    write_json(run_dir / STATUS_FILE, status)
    return {**status, "skipped": False}
