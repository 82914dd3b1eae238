"""The combined tables of a job: every current run's tables, in manifest order, with the plan's
error estimates joined. It reads the run folders and never writes them."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import platform
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import polars as pl

from roadtex._core import __version__
from roadtex.archive.arrow_schema import table_options
from roadtex.archive.comparison_tables import COMPARISON_TABLES, edge_effect_table
from roadtex.archive.plan import JobPlan, RunPlan
from roadtex.archive.reading import is_surface_run
from roadtex.archive.schemas import (
    AREAL_SCHEMA,
    BAND_SCHEMA,
    ERROR_SCHEMA,
    EXAMPLE_SCHEMA,
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
    units,
)
from roadtex.archive.store import checksums, file_sha256, read_status, write_atomically, write_json
from roadtex.budget.estimate import below_typical_factor

#: Tables of some runs only (line runs: sections; surface runs: areal parameters), combined from those that have them.
SECTION_TABLES = {"sections": SECTION_SCHEMA, "section_bands": SECTION_BAND_SCHEMA, "areal": AREAL_SCHEMA}
#: Units of ProcessingOptions' fields, recorded in parameters.json.
OPTION_UNITS = {"youngs_moduli": "Pa", "mean_pressure": "Pa", "segment_length": "m", "segment_overlap": "m",
                "dx": "m", "speed_kmh": "km/h", "tol": "1", "poisson": "1", "error_budget_db": "dB",
                "section_length": "m"}


def software_versions() -> dict[str, str]:
    """Versions of roadtex and what it computes with (recorded in parameters.json)."""
    return {"roadtex": __version__, "python": platform.python_version(), "numpy": np.__version__,
            "polars": pl.__version__, "platform": platform.platform()}


def combine(manifest: pl.DataFrame, out_dir: str | os.PathLike[str], plan: JobPlan, *,
            study: pl.DataFrame | None = None, keep: bool = True) -> dict[str, Path]:
    """Concatenates the per-run tables of the runs in ``manifest`` (in its order) into the combined
    tables, with ``plan``'s error estimates, and writes parameters.json (the user's options and the
    plan). Only runs whose status holds the job's options count; stale folders are ignored. The
    tables are streamed from the per-run files (polars' streaming sink), so memory does not grow
    with the archive. With ``keep``, the previous job's tables are kept where nothing they depend on
    changed and their checksums hold (:func:`kept_tables`); ``keep=False`` (``--force``) writes them anew.
    """
    out = Path(out_dir)
    options = plan.options
    options_fingerprint = options.fingerprint()
    parts: dict[str, list[Path]] = {"segments": [], "bands": [], "runs": [], "examples": [], "surface_examples": [],
                                    **{name: [] for name in COMPARISON_TABLES}, **{name: [] for name in SECTION_TABLES}}
    errors: list[dict[str, Any]] = []
    surface_error_files: list[Path] = []
    pilot_notes: dict[str, str] = {}
    entries: dict[str, RunPlan] = {}
    included: list[tuple[str, str, str | None]] = []
    for run in manifest.iter_rows(named=True):
        run_dir = out / "runs" / run["run_id"]
        status = read_status(run_dir)
        if status is None or status.get("options_fingerprint") != options_fingerprint:
            continue
        included.append((str(run["run_id"]), str(run["path"]), status.get("fingerprint")))
        if status["state"] == "error":
            errors.append({name: status.get(name) for name in ERROR_SCHEMA})
            continue
        entries[run["run_id"]] = RunPlan(**status["plan"])
        parts["segments"].append(run_dir / "segments.parquet")
        parts["bands"].append(run_dir / "bands.parquet")
        parts["runs"].append(run_dir / "run.parquet")
        if (run_dir / "example.parquet").exists():
            parts["examples"].append(run_dir / "example.parquet")
            for name in COMPARISON_TABLES:
                parts[name].append(run_dir / f"{name}.parquet")
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
    key = combined_key(plan, included)
    kept = kept_tables(out, key, [*parts, "pilot", "errors"]) if keep else None
    if kept is not None:   # nothing new since the last job: its tables, verified
        return write_parameters(out, plan, manifest.height, pilot_notes, key, {**kept,
                                                                                "edge_effect": kept_edge_effect(out, plan)})
    estimates = run_estimates(plan, entries)
    surface_ids = [run["run_id"] for run in manifest.iter_rows(named=True) if is_surface_run(run)]
    own = surface_estimates(surface_error_files, options.error_budget_db)
    written = {}
    for name, files in parts.items():
        path = out / f"{name}.parquet"
        metadata = table_options(TABLES[name])
        if files:
            query = with_plan(pl.scan_parquet(files, schema=schemas[name]), name, estimates, surface_ids,
                              own).select([pl.col(c).cast(t) for c, t in combined[name].items()])
            write_atomically(path, lambda p, q=query, m=metadata: q.sink_parquet(p, statistics=True, **m))
        else:
            empty = pl.DataFrame(schema=combined[name])
            write_atomically(path, lambda p, t=empty, m=metadata: t.write_parquet(p, statistics=True, **m))
        written[name] = path
    written["edge_effect"] = kept_edge_effect(out, plan)
    pilot = (study.select([pl.col(c).cast(t) if c in study.columns else pl.lit(None, dtype=t).alias(c)
                           for c, t in PILOT_SCHEMA.items()])
             if study is not None and study.height else pl.DataFrame(schema=PILOT_SCHEMA))
    write_atomically(out / "pilot.parquet", lambda p: pilot.write_parquet(p, **table_options(TABLES["pilot"])))
    written["pilot"] = out / "pilot.parquet"
    error_table = pl.DataFrame(errors, schema=ERROR_SCHEMA)
    write_atomically(out / "errors.parquet", lambda p: error_table.write_parquet(p, **table_options(TABLES["errors"])))
    written["errors"] = out / "errors.parquet"
    return write_parameters(out, plan, manifest.height, pilot_notes, key, written)


def write_parameters(out: Path, plan: JobPlan, runs: int, pilot_notes: dict[str, str], key: str | None,
                     written: dict[str, Path]) -> dict[str, Path]:
    """parameters.json: the options, the plan, units, versions, the checksums of the combined tables
    ``written`` (verified by the report, and by the next job before it keeps them) and ``key``
    (:func:`combined_key`); returns ``written`` with it (and the runs' folder with kept profiles)."""
    options = plan.options
    write_json(out / "parameters.json", {
        "options": dataclasses.asdict(options), "options_fingerprint": options.fingerprint(),
        "plan": plan.summary(), "combined_key": key,
        # surface runs whose areal pilot could not run (their levels have no error estimate), and why
        "surface_pilot_notes": pilot_notes,
        "units": {"options": OPTION_UNITS, **{name: units(columns) for name, columns in TABLES.items()}},
        "versions": software_versions(), "runs": runs,
        # verified by the report before it draws anything (a table damaged since is refused)
        "checksums": checksums(out, [path.name for path in written.values()]),
    })
    written = {**written, "parameters": out / "parameters.json"}
    if options.keep_profiles:
        written["profiles"] = out / "runs"
    return written


def combined_key(plan: JobPlan, included: list[tuple[str, str, str | None]]) -> str:
    """What the combined tables depend on: the runs they hold, in order, with their fingerprints,
    the options, the plan's decisions (a kept pilot's study rows are its own, so pilot.parquet is
    too) and the version."""
    decided = [(p.name, p.data_dx, p.refine, p.tol, sorted(p.band_error_db.items()), p.worst_error_db,
                p.within_budget, sorted(p.interpolant_spread_db.items()), p.pilot_runs) for p in plan.pilots]
    payload = json.dumps([plan.options.fingerprint(), __version__, included, decided, plan.failed_pilots,
                          plan.unread_runs], sort_keys=True, default=str)
    return hashlib.sha256(payload.encode()).hexdigest()


def kept_tables(out: Path, key: str | None, names: list[str]) -> dict[str, Path] | None:
    """The combined tables ``names`` of the previous job when its parameters.json holds ``key`` and
    every table still matches its recorded checksum; else None (they are written anew)."""
    if key is None:
        return None
    try:
        previous = json.loads((out / "parameters.json").read_text(encoding="utf-8"))
        recorded = previous["checksums"]
        if previous.get("combined_key") != key:
            return None
        paths = {name: out / f"{name}.parquet" for name in names}
        if all(recorded.get(path.name) == file_sha256(path) for path in paths.values()):
            return paths
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        pass
    return None


def kept_edge_effect(out: Path, plan: JobPlan) -> Path:
    """edge_effect.parquet: solved once for the job's load and moduli, and kept while the previous
    job's parameters.json records the same options and the file's checksum (a rerun solves nothing)."""
    path = out / "edge_effect.parquet"
    try:
        previous = json.loads((out / "parameters.json").read_text(encoding="utf-8"))
        if (previous.get("options_fingerprint") == plan.options.fingerprint()
                and previous.get("checksums", {}).get(path.name) == file_sha256(path)):
            return path
    except (OSError, ValueError, AttributeError):
        pass
    edge = edge_effect_table(plan.options)
    write_atomically(path, lambda p: edge.select(list(TABLES["edge_effect"])).write_parquet(
        p, **table_options(TABLES["edge_effect"])))
    return path


def run_estimates(plan: JobPlan, entries: dict[str, RunPlan]) -> tuple[pl.DataFrame, pl.DataFrame]:
    """Each line run's error estimates from its plan entry (its group's pilot, or the largest of any
    group where none covered it): per (run, band) ``level_error_db`` (the group's, for a level at its
    typical band level: :func:`with_plan` scales it per row), ``interpolant_spread_db``,
    ``sampling_limited`` and ``typical_over`` (the rows whose median is the typical level: the run's
    pilot group, or the run itself); per run ``worst_level_error_db``, ``within_budget``, ``speedup`` and
    ``error_source``. Surface runs have their own areal pilot's (:func:`surface_estimates`)."""
    band_rows: list[tuple[str, int, float, float | None, bool | None, str]] = []
    run_rows: list[tuple[str, float | None, bool | None, float | None, str | None]] = []
    budget = plan.budget_db
    for run_id, entry in entries.items():
        if entry.kind != "line":
            continue
        errors, spread, worst, within = plan.band_errors(entry)
        # the rows whose median level a row's statement is scaled from: its pilot group's (its own run's
        # where no pilot covered it)
        typical_over = entry.group or run_id
        band_rows += [(run_id, band, error, spread.get(band), None if band not in spread or budget is None
                       else bool(spread[band] > budget), typical_over)
                      for band, error in errors.items() if np.isfinite(error)]
        pilot = next((p for p in plan.pilots if p.name == entry.group), None)
        speedup = pilot.work_speedup if pilot is not None and np.isfinite(pilot.work_speedup) else plan.work_speedup
        run_rows.append((run_id, worst, within, speedup if budget is not None else None, entry.error_source))
    bands = pl.DataFrame(band_rows, schema={"run_id": pl.String, "band": pl.Int64, "level_error_db": pl.Float64,
                                            "interpolant_spread_db": pl.Float64, "sampling_limited": pl.Boolean,
                                            "typical_over": pl.String},
                         orient="row")
    runs = pl.DataFrame(run_rows, schema={"run_id": pl.String, "worst_level_error_db": pl.Float64,
                                          "within_budget": pl.Boolean, "line_speedup": pl.Float64,
                                          "error_source": pl.String}, orient="row")
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


def below_typical(rows: pl.Expr) -> pl.Expr:
    """Per row of ``rows`` (line runs' rows with a group statement), the factor on its group's stated
    error: the larger of its enveloped and pressure levels' :func:`roadtex.budget.estimate.below_typical_factor`
    against the median over the reported rows of its group (``typical_over``), band and modulus."""
    factors = []
    for level in ("enveloped_level", "pressure_level"):
        finite = rows & pl.col("reported") & pl.col(level).is_finite()
        typical = pl.col(level).filter(finite).median().over("typical_over", "band", "youngs_modulus")
        factors.append(pl.when(finite).then(below_typical_factor(pl.col(level), typical)))
    return pl.max_horizontal(pl.lit(1.0), *factors)


def with_plan(query: pl.LazyFrame, name: str, estimates: tuple[pl.DataFrame, pl.DataFrame],
              surface_ids: Sequence[str] = (),
              surface_own: tuple[pl.DataFrame, pl.DataFrame] | None = None) -> pl.LazyFrame:
    """The plan's columns added to a combined table: each band row's error estimate, each run's
    worst error, budget verdict, speed-up, time saved and error source (``estimates``, from
    :func:`run_estimates`; null where the plan has none). The rows of the surface runs
    ``surface_ids`` get their own areal pilot's (``surface_own``, from :func:`surface_estimates`;
    null where there is none)."""
    band_errors, run_verdicts = estimates
    own_bands, own_runs = surface_own if surface_own is not None else surface_estimates([], None)
    surface = pl.col("run_id").is_in(pl.Series(list(surface_ids), dtype=pl.String).implode())
    if name == "bands":
        joined = (query.join(band_errors.lazy(), on=["run_id", "band"], how="left", maintain_order="left")
                  .join(own_bands.lazy(), on=["run_id", "model", "band"], how="left", maintain_order="left"))
        # the line pilot measures the line model of line runs only
        line_only = surface | (pl.col("model") == "areal")
        stated_rows = ~line_only & pl.col("level_error_db").is_not_null()
        return joined.with_columns(pl.when(surface).then(pl.col("surface_error_db"))
                                   .when(pl.col("model") == "areal").then(None)
                                   .otherwise(pl.col("level_error_db") * below_typical(stated_rows))
                                   .alias("level_error_db"),
                                   *[pl.when(line_only).then(None).otherwise(pl.col(c)).alias(c)
                                     for c in ("interpolant_spread_db", "sampling_limited")])
    if name == "runs":
        # Only deterministic numbers go in the tables (a re-run, a resumed run and the Dask engine must
        # give the same bits): the saving as a share of the solver work; measured seconds are in
        # parameters.json and pilot.parquet.
        joined = (query.join(run_verdicts.lazy(), on="run_id", how="left", maintain_order="left")
                  .join(own_runs.lazy(), on="run_id", how="left", maintain_order="left"))
        ratio = pl.when(surface).then(pl.col("surface_speedup")).otherwise(pl.col("line_speedup"))
        source = (pl.when(surface & pl.col("surface_worst_db").is_not_null()).then(pl.lit("its own areal pilot"))
                  .when(surface).then(None).otherwise(pl.col("error_source")))
        return joined.with_columns(
            pl.when(surface).then(pl.col("surface_worst_db")).otherwise(pl.col("worst_level_error_db"))
            .alias("worst_level_error_db"),
            pl.when(surface).then(pl.col("surface_within")).otherwise(pl.col("within_budget")).alias("within_budget"),
            ratio.cast(pl.Float64).alias("speedup"),
            (1.0 - 1.0 / ratio).cast(pl.Float64).alias("time_saved_fraction"),
            source.cast(pl.String).alias("error_source"))
    return query
