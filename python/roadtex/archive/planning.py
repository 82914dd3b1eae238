"""Making the job's plan (:class:`~roadtex.archive.plan.JobPlan`): the error budget's pilots, one per
(device, pavement) group and sampling interval, or the ones the output folder kept from an earlier
job when nothing they depend on changed (:mod:`roadtex.archive.kept_pilots`)."""

from __future__ import annotations

import hashlib
import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from roadtex.archive.kept_pilots import KeptGroup, keep_group, kept_groups, pilot_key
from roadtex.archive.options import ProcessingOptions
from roadtex.archive.plan import GroupPilot, JobPlan, spacing_key
from roadtex.archive.reading import group_key, reader_options
from roadtex.archive.store import file_sha256
from roadtex.budget import choose_setting
from roadtex.errors import ErrorBudgetWarning, RoadtexWarning
from roadtex.profiles.plausibility import implausible_texture, judged_once, stated_distance_unit
from roadtex.profiles.profile import Profile
from roadtex.profiles.readers import read_profile
from roadtex.spectra.bands import nominal_label

#: Runs read per (device, pavement) group for the pilot (spread evenly over the group).
PILOT_RUNS_PER_GROUP = 3
#: Runs tried per sampled run when sampled runs cannot be read (see :func:`readable`).
PLAN_READ_ATTEMPTS = 3


def spread(runs: list[dict[str, Any]], count: int) -> list[dict[str, Any]]:
    """Up to ``count`` runs spread evenly over ``runs`` (all of them when there are few)."""
    if len(runs) <= count:
        return list(runs)
    picks = np.unique(np.linspace(0, len(runs) - 1, count).round().astype(int))
    return [runs[i] for i in picks]


def readable(runs: list[dict[str, Any]], options: ProcessingOptions, count: int,
             unread: dict[str, str]) -> list[tuple[dict[str, Any], Profile]]:
    """Up to ``count`` runs, spread evenly over ``runs``, that can be read, are plausible road
    texture in metres (or any, with ``options.allow_implausible``) and hold at least one segment,
    with their profiles. A sampled run that is not is recorded in ``unread``
    (run id -> why) and its nearest untried neighbour in ``runs`` takes its place, so the sample
    stays spread; at most :data:`PLAN_READ_ATTEMPTS` runs are tried per sampled one."""
    picks = [i for i, run in enumerate(runs) if any(run is p for p in spread(runs, count))]
    tried = set(picks)
    read: list[tuple[dict[str, Any], Profile]] = []
    for pick in picks:
        neighbours = sorted((i for i in range(len(runs)) if i not in tried), key=lambda i: (abs(i - pick), i))
        for index in [pick] + neighbours[:PLAN_READ_ATTEMPTS - 1]:
            tried.add(index)
            run = runs[index]
            try:
                with warnings.catch_warnings(), judged_once():   # judged below, once
                    warnings.simplefilter("ignore", RoadtexWarning)
                    profile = read_profile(run["path"], format=run.get("format"), **reader_options(run, options))
            except Exception as exc:  # noqa: BLE001 - the run's own processing records the failure too
                unread[str(run["run_id"])] = f"{type(exc).__name__}: {exc}"
                continue
            reason = implausible_texture(profile.heights, profile.dx, str(run["path"]),
                                         interval_stated=stated_distance_unit(profile.metadata) is not None)
            if options.allow_implausible:   # solved as read, as the run is
                reason = None
            if reason is None and profile.length < options.segment_length:
                # no segment to pilot on (the run fails on its own): a neighbour stands in for it
                reason = f"{profile.length:.4g} m long, shorter than one {options.segment_length:g} m segment"
            if reason is not None:
                unread[str(run["run_id"])] = reason
                continue
            read.append((run, profile))
            break
    return read


def plan_job(runs: list[dict[str, Any]], options: ProcessingOptions, *, threads: int | None = None,
             out: Path | None = None, reuse: bool = True) -> tuple[JobPlan, pl.DataFrame]:
    """The job's plan for the line runs ``runs`` (manifest rows), and the pilots' study rows (one per
    group, setting and band; for pilot.parquet and the report's speed-against-error figure).

    With an error budget, each (device, pavement) group's pilot reads up to
    :data:`PILOT_RUNS_PER_GROUP` of its runs spread over it, and measures one pilot per sampling
    interval among them. With ``out``, a group whose pilot that folder kept (same options, same
    roadtex, the pilot's files unchanged and still the group's) reuses it without reading or solving
    anything, and each pilot made is kept there for the next job; ``reuse`` False (``--force``) makes
    every pilot again.
    """
    if not runs:   # surface runs only: each has its own pilot, spacings and tolerance
        return JobPlan(options=options, source="no line run to plan for (surface runs: their own spacings, and their "
                                                "own pilots' tolerances and error estimates)"), pl.DataFrame()
    if options.error_budget_db is None:
        return JobPlan.given(options), pl.DataFrame()
    # the pilots sample runs by position: in a stable order, so that the same runs listed in another
    # order give the same plan (32 runs reversed gave worst errors of 0.381 against 0.415 dB)
    runs = sorted(runs, key=lambda run: (str(run["run_id"]), str(run["path"])))
    groups: dict[str, list[dict[str, Any]]] = {}
    for run in runs:
        groups.setdefault(group_key(run), []).append(run)
    key = pilot_key(options)
    kept = kept_groups(out, key) if out is not None else {}
    made: list[KeptGroup] = []
    reused: list[str] = []
    for name, members in groups.items():
        previous = kept.get(name)
        if previous is not None and reuse and still_valid(previous, members, options):
            made.append(previous)
            reused += [p.name for p in previous.pilots]
            continue
        group = pilot_group(name, members, options, threads)
        if out is not None:
            keep_group(out, key, group)
        made.append(group)
    pilots = tuple(p for g in made for p in g.pilots)
    failed = {k: v for g in made for k, v in g.failed.items()}
    unread = {k: v for g in made for k, v in g.unread.items()}
    for group in made:
        for name, why in group.failed.items():
            warnings.warn(f"the error budget pilot of group {name!r} could not run ({why}); its runs get the largest "
                          "estimate of any group", ErrorBudgetWarning, stacklevel=3)
    studies = [g.study for g in made if g.study.height]
    source = (f"error budget pilots of {len(pilots)} group(s)" + (f", {len(reused)} kept from an earlier job"
                                                               if reused else "")
              if pilots else "no pilot possible: no run could be read and cut into segments")
    plan = JobPlan(options=options, source=source, pilots=pilots, failed_pilots=failed, unread_runs=unread,
                   reused_pilots=tuple(reused))
    missed = [p for p in pilots if not p.within_budget]
    if missed:
        where = (f"at the given dx of {options.dx * 1e3:g} mm" if options.dx is not None
                 else "at the data's sampling of every group")
        warnings.warn(
            f"the error budget of {options.error_budget_db:g} dB cannot be met {where}: the smallest estimated "
            f"error in the tyre/road noise bands is {'; '.join(missed_budget(p) for p in missed)}; the job runs at "
            "the cheapest setting near that floor and states the error of every band (bands.parquet level_error_db)",
            ErrorBudgetWarning, stacklevel=3)
    return plan, pl.concat(studies, how="diagonal_relaxed") if studies else pl.DataFrame()


def has_untried_runs(tried: int, members: int) -> bool:
    """Whether a group of ``members`` runs holds runs its pilot never tried (it tried ``tried``, read
    or found unreadable): its statements then extrapolate to them (``choose_setting(sampled=...)``),
    and a kept pilot stays valid only while that is so (:func:`still_valid`)."""
    return tried < members


def input_digest(run: dict[str, Any], options: ProcessingOptions) -> str:
    """What a pilot tried of a run: its file's bytes (SHA-256; "missing" when it cannot be opened)
    with the reader options of its manifest row (a dx, a unit, a drop-out code read it otherwise)."""
    try:
        content = file_sha256(run["path"])
    except OSError:
        content = "missing"
    reading = json.dumps(reader_options(run, options), sort_keys=True, default=str)
    return f"{content}:{hashlib.sha256(reading.encode()).hexdigest()[:16]}"


def still_valid(group: KeptGroup, members: list[dict[str, Any]], options: ProcessingOptions) -> bool:
    """Whether a kept pilot still describes its group: every run it tried (read, or found unreadable)
    is still one of the group's rows (same id, same file), its file and its row's reader options
    unchanged (:func:`input_digest`), and the group still holds runs it never tried exactly when it
    did then (its statements extrapolate to those: ``choose_setting(sampled=...)``)."""
    rows = {str(run["run_id"]): run for run in members}
    for run_id, (path, digest) in group.inputs.items():
        run = rows.get(run_id)
        if run is None or str(run["path"]) != path or input_digest(run, options) != digest:
            return False
    return has_untried_runs(len(group.inputs), group.members) == has_untried_runs(len(group.inputs), len(members))


def pilot_group(name: str, members: list[dict[str, Any]], options: ProcessingOptions,
                threads: int | None) -> KeptGroup:
    """The pilots of one (device, pavement) group: one per sampling interval among the runs read."""
    unread: dict[str, str] = {}
    by_dx: dict[float, list[tuple[dict[str, Any], Profile]]] = {}
    read = readable(members, options, PILOT_RUNS_PER_GROUP, unread)
    for run, profile in read:
        by_dx.setdefault(spacing_key(profile.dx), []).append((run, profile))
    pilots, failed, studies = [], {}, []
    for spacing, sample in by_dx.items():
        # the spacing always named: a run's rows say the same in any archive (alone, or among other samplings)
        label = f"{name} @ {spacing * 1e3:.3g} mm"
        try:
            # the pilot's runs were judged plausible by readable(): its solves and spectra do not judge them again
            with judged_once():
                choice = choose_setting(
                    [profile for _, profile in sample], youngs_moduli=options.youngs_moduli,
                    mean_pressure=options.mean_pressure, segment_length=options.segment_length,
                    budget_db=options.error_budget_db, forced_dx=options.dx, forced_tol=options.tol,
                    forced_refine=options.refine, poisson=options.poisson, band_kind=options.band_kind,
                    band_method=options.band_method, spike_alpha=options.spike_alpha,
                    max_iterations=options.max_iterations, threads=threads, interpolant=options.interpolant,
                    # runs of the group it never tried are spoken for too: their extremes are not in the sample
                    # (the runs it could not read fail on their own; other samplings have their own pilots)
                    sampled=has_untried_runs(len(read) + len(unread), len(members)))
        except Exception as exc:  # noqa: BLE001 - e.g. runs too short for one segment: they fail on their own
            failed[label] = f"{type(exc).__name__}: {exc}"   # recorded (parameters.json) and warned
            continue
        study = choice.study.with_columns(
            pl.lit(label).alias("group"), ((pl.col("dx") == choice.dx) & (pl.col("refine") == choice.refine)
                                           & (pl.col("tol") == choice.tol) & pl.col("choosable")).alias("chosen"))
        chosen_work = study.filter(pl.col("chosen"))["work_per_metre"].max()
        finest_work = study.filter(pl.col("reference"))["work_per_metre"].max()
        pilots.append(GroupPilot(
            name=label, key=name, spacing=spacing, data_dx=float(choice.dx), refine=int(choice.refine),
            tol=float(choice.tol), band_error_db={int(b): float(e) for b, e in choice.band_error_db.items()},
            worst_error_db=float(choice.worst_error_db), within_budget=bool(choice.within_budget),
            interpolant_spread_db={int(b): float(v) for b, v in choice.interpolant_spread_db.items()},
            pilot_runs=tuple(str(run["run_id"]) for run, _ in sample),
            seconds_per_metre=float(choice.seconds_per_metre),
            finest_seconds_per_metre=float(choice.finest_seconds_per_metre),
            work_speedup=float(finest_work / chosen_work) if chosen_work and finest_work else float("nan"),
            pilot_seconds=float(choice.pilot_seconds)))
        studies.append(study)
    # every run the pilot tried, read or not: a file mended (or its row's options changed) makes it again
    tried = [run for run, _ in read] + [run for run in members if str(run["run_id"]) in unread]
    inputs = {str(run["run_id"]): (str(run["path"]), input_digest(run, options)) for run in tried}
    study = pl.concat(studies, how="diagonal_relaxed") if studies else pl.DataFrame()
    return KeptGroup(name=name, pilots=tuple(pilots), failed=failed, unread=unread, inputs=inputs, study=study,
                     members=len(members))


def missed_budget(pilot: GroupPilot) -> str:
    """A pilot's smallest error in the budget bands, in words: "name: 0.4 dB", or, where some budget
    bands are not reported at its interval (too coarse to resolve their wavelengths, so no error can
    be stated: an infinite estimate), which bands and the largest error of the others."""
    if np.isfinite(pilot.worst_error_db):
        return f"{pilot.name}: {pilot.worst_error_db:.3g} dB"
    unreported = sorted(b for b, e in pilot.band_error_db.items() if not np.isfinite(e))
    finite = [e for e in pilot.band_error_db.values() if np.isfinite(e)]
    span = nominal_label(unreported[0]) + ("" if len(unreported) == 1 else f" to {nominal_label(unreported[-1])}")
    others = f"; the bands it reports err by up to {max(finite):.3g} dB" if finite else ""
    return (f"{pilot.name}: no error can be stated for {len(unreported)} of its budget bands ({span} mm), which dx "
            f"{pilot.data_dx * 1e3:g} mm is too coarse to report{others}")

