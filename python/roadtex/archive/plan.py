"""The job's plan: one sampling interval and one solver tolerance for every run, chosen before any
run is processed, with the numerical error of every band level they give.

- **One sampling interval for all runs.** Results of the contact model depend on the sampling
  interval (the rubber bridges what it cannot resolve), so two devices measuring the same road at
  0.04 and 0.5 mm would give different contact fractions if each run kept its own. Every run is
  solved at one interval; runs sampled more coarsely are interpolated to it, runs sampled more
  finely averaged down.
- **The error budget** (``ProcessingOptions.error_budget_db``, on by default): a pilot
  (:func:`roadtex.budget.choose_setting`) per group of runs of the same device and pavement, on a
  few segments of up to :data:`PILOT_RUNS_PER_GROUP` runs spread over the group, measures how the
  levels converge with the interval and the tolerance and picks the cheapest setting within the
  budget. The job takes the finest interval and the tightest tolerance any group needs, so every
  group stays within the budget. Each run's rows carry its own group's error estimates (a group is
  a device, a pavement and a sampling interval); a run whose group had no pilot gets the largest
  estimate of any group.
- **Without a budget**: the given ``dx`` (or the finest nominal interval among a sample of the
  runs) and the given ``tol`` (or :data:`DEFAULT_TOL`), and no error estimate.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import polars as pl

from roadtex.archive.options import DEFAULT_TOL, ProcessingOptions
from roadtex.budget import choose_setting
from roadtex.errors import ErrorBudgetWarning, RoadtexWarning
from roadtex.profiles.plausibility import implausible_texture, judged_once, stated_distance_unit
from roadtex.profiles.profile import Profile
from roadtex.profiles.readers import READ_OPTIONS, read_profile
from roadtex.spectra.bands import nominal_label

#: Runs read per (device, pavement) group for the pilot (spread evenly over the group).
PILOT_RUNS_PER_GROUP = 3
#: Runs read to find the finest interval when there is no budget (spread over the manifest).
PLAN_SAMPLE_RUNS = 8
#: Runs tried per sampled run when sampled runs cannot be read (see :func:`readable`).
PLAN_READ_ATTEMPTS = 3


@dataclass(frozen=True)
class GroupError:
    """One pilot's error estimates, for the runs of its group.

    Attributes:
        key: the (device, pavement) group, as :func:`group_key` writes it.
        spacing: the runs' nominal sampling interval (m, two significant digits).
        band_error_db: band number -> upper estimate (dB) of the numerical error of any level of
            that band for the group's runs at the job's setting.
        worst_error_db: the largest of those in the budget bands (dB).
        within_budget: whether that is within the budget.
        refine: the model grid refinement the pilot chose for the group.
        model_dx: the group's model grid interval (m): its runs are solved on it.
        interpolant_spread_db: band number -> what the group's sampling cannot tell (dB): the
            spread of the converged levels between interpolants of the readings.
    """

    key: str
    spacing: float
    band_error_db: dict[int, float]
    worst_error_db: float
    within_budget: bool
    refine: int = 1
    interpolant_spread_db: dict[int, float] = field(default_factory=dict)
    model_dx: float | None = None


@dataclass(frozen=True)
class JobPlan:
    """What the job solves every run at, and the numerical error that gives.

    Attributes:
        dx: sampling interval (m).
        tol: solver tolerance (relative residual).
        refine: the model grid's refinement k: the contact model is solved every ``dx / refine``.
        source: how they were chosen.
        budget_db: the error budget (dB), None when off.
        within_budget: whether every group's estimate is within the budget (None without budget).
        worst_error_db: largest estimated error (dB) in the budget bands, any group (None without budget).
        band_error_db: band number -> upper estimate (dB) of the numerical error of any level of
            that band (texture, enveloped, pressure; any segment, modulus and group).
        interpolant_spread_db: band number -> the largest spread (dB) of any group's converged
            levels between interpolants of the readings: what the sampling cannot tell.
        seconds_per_metre: the pilots' measured solve time per metre at (dx, tol) (s/m).
        finest_seconds_per_metre: the same at the reference (file dx refined K times, tol 1e-10) (s/m).
        speedup: the finest setting's work over the chosen one's (iterations x N log2 N per metre,
            the pilots' count: unlike the times, the machine's load does not change it).
        pilot_seconds: wall time of the pilots (s).
        groups: (device, pavement) groups and the runs each pilot read.
        group_errors: each pilot's estimates by group name (the names of ``groups``).
        failed_pilots: group name -> why its pilot could not run (the exception's type and
            message); those groups' runs get the largest estimate of any group.
        unread_runs: run id -> why the plan could not use a run it sampled (unreadable, or not
            plausible road texture in metres); another run of the group took its place where
            there was one. The run's own processing records its failure too.
    """

    dx: float
    tol: float
    source: str
    refine: int = 1
    budget_db: float | None = None
    within_budget: bool | None = None
    worst_error_db: float | None = None
    band_error_db: dict[int, float] = field(default_factory=dict)
    interpolant_spread_db: dict[int, float] = field(default_factory=dict)
    seconds_per_metre: float | None = None
    finest_seconds_per_metre: float | None = None
    speedup: float | None = None
    pilot_seconds: float = 0.0
    groups: dict[str, list[str]] = field(default_factory=dict)
    group_errors: dict[str, GroupError] = field(default_factory=dict)
    failed_pilots: dict[str, str] = field(default_factory=dict)
    unread_runs: dict[str, str] = field(default_factory=dict)

    def group_of(self, run: dict[str, Any], file_dx: float | None) -> GroupError | None:
        """The pilot group of a manifest row whose file is sampled at ``file_dx`` (m), or None
        when no pilot covered its device, pavement and sampling interval."""
        if file_dx is None or not np.isfinite(file_dx):
            return None
        key, spacing = group_key(run), float(f"{file_dx:.2g}")
        return next((g for g in self.group_errors.values() if g.key == key and g.spacing == spacing), None)

    def resolved(self, options: ProcessingOptions) -> ProcessingOptions:
        """``options`` with the plan's interval, refinement and tolerance filled in (what the runs
        are solved with); ``tol_from_budget`` when the budget, not the caller, chose the tolerance."""
        return dataclasses.replace(options, dx=self.dx, tol=self.tol, refine=self.refine,
                                   group_model_dx=tuple((g.key, g.spacing, g.model_dx) for g in self.group_errors.values()
                                                        if g.model_dx is not None),
                                   tol_from_budget=options.tol is None and options.error_budget_db is not None,
                                   refine_from_budget=options.refine is None and options.error_budget_db is not None)

    def summary(self) -> dict[str, Any]:
        """The plan as JSON-ready values (parameters.json)."""
        as_dict = dataclasses.asdict(self)
        as_dict["band_error_db"] = {str(k): v for k, v in self.band_error_db.items()}
        as_dict["interpolant_spread_db"] = {str(k): v for k, v in self.interpolant_spread_db.items()}
        for group in as_dict["group_errors"].values():
            group["band_error_db"] = {str(k): v for k, v in group["band_error_db"].items()}
            group["interpolant_spread_db"] = {str(k): v for k, v in group["interpolant_spread_db"].items()}
        return as_dict


def reader_options(run: dict[str, Any], options: ProcessingOptions) -> dict[str, object]:
    """The read_profile options of one run: the job's defaults, overridden by the run's manifest columns."""
    chosen = dict(options.reader_defaults)
    for name in READ_OPTIONS:
        value = run.get(name)
        if value is not None and not (isinstance(value, float) and np.isnan(value)):
            chosen[name] = value
    for name in ("distance_column", "height_column"):
        value = chosen.get(name)
        if isinstance(value, str) and value.strip().lstrip("-").isdigit():
            chosen[name] = int(value)   # a column index given in a CSV manifest
    return chosen


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
                reason = (f"{profile.length:.4g} m long, shorter than one {options.segment_length:g} m segment")
            if reason is not None:
                unread[str(run["run_id"])] = reason
                continue
            read.append((run, profile))
            break
    return read


def group_key(run: dict[str, Any]) -> str:
    return f"{run.get('device') or 'any device'} / {run.get('pavement') or 'any pavement'}"


def run_refine(run: dict[str, Any], file_dx: float, dx: float, options: ProcessingOptions) -> int:
    """The model grid refinement of a line run (file sampled every ``file_dx`` m, conditioned to
    ``dx`` m): its pilot group's model grid (``options.group_model_dx``), else ``options.refine``."""
    key, spacing = group_key(run), float(f"{file_dx:.2g}")
    for group, group_spacing, model_dx in options.group_model_dx:
        if group == key and group_spacing == spacing:
            return max(1, int(np.ceil(dx / model_dx * (1.0 - 1e-9))))
    return int(options.refine or 1)


def plan_job(runs: list[dict[str, Any]], options: ProcessingOptions, *, threads: int | None = None) -> tuple[JobPlan, pl.DataFrame]:
    """Chooses the job's sampling interval and tolerance (see the module docstring).

    Returns:
        The plan, and the pilots' study rows (one per group, setting and band; empty without a
        budget) for pilot.parquet and the report's speed-against-error figure.
    """
    # the pilots sample runs by position: in a stable order, so that the same runs listed in another
    # order give the same plan (32 runs reversed gave worst errors of 0.381 against 0.415 dB)
    runs = sorted(runs, key=lambda run: (str(run["run_id"]), str(run["path"])))
    if options.error_budget_db is None:
        return plan_without_budget(runs, options), pl.DataFrame()
    if not runs:   # surface runs only: each has its own pilot, spacings and tol
        return JobPlan(dx=options.dx or 0.5e-3, tol=DEFAULT_TOL if options.tol is None else options.tol,
                       refine=options.refine or 1,
                       source="no line run to plan for (surface runs: their own spacings, and their own "
                              "pilots' tolerances and error estimates)"), pl.DataFrame()
    groups: dict[str, list[dict[str, Any]]] = {}
    for run in runs:
        groups.setdefault(group_key(run), []).append(run)
    choices, studies, read_runs, group_errors = [], [], {}, {}
    failed: dict[str, str] = {}
    unread: dict[str, str] = {}
    for key, members in groups.items():
        # one pilot per sampling interval within the group (a pilot compares runs on one grid)
        by_dx: dict[float, list[tuple[dict[str, Any], Profile]]] = {}
        for run, profile in readable(members, options, PILOT_RUNS_PER_GROUP, unread):
            by_dx.setdefault(float(f"{profile.dx:.2g}"), []).append((run, profile))
        for spacing, read in by_dx.items():
            name = key if len(by_dx) == 1 else f"{key} @ {spacing * 1e3:g} mm"
            try:
                # the pilot's runs were judged plausible by readable(): its solves and spectra do not
                # judge them again
                with judged_once():
                    choice = choose_setting(
                        [profile for _, profile in read], youngs_moduli=options.youngs_moduli,
                        mean_pressure=options.mean_pressure, segment_length=options.segment_length,
                        budget_db=options.error_budget_db, forced_dx=options.dx, forced_tol=options.tol,
                        forced_refine=options.refine,
                        poisson=options.poisson, band_kind=options.band_kind, spike_alpha=options.spike_alpha,
                        max_iterations=options.max_iterations, threads=threads)
            except Exception as exc:  # noqa: BLE001 - e.g. runs too short for one segment: they fail on their own
                # recorded (parameters.json's plan) and warned, never dropped silently
                failed[name] = f"{type(exc).__name__}: {exc}"
                warnings.warn(f"the error budget pilot of group {name!r} (runs {', '.join(r['run_id'] for r, _ in read)}) "
                              f"could not run ({failed[name]}); its runs get the largest estimate of any group",
                              ErrorBudgetWarning, stacklevel=3)
                continue
            choices.append(choice)
            read_runs[name] = [run["run_id"] for run, _ in read]
            group_errors[name] = GroupError(key=key, spacing=spacing, band_error_db=dict(choice.band_error_db),
                                            worst_error_db=float(choice.worst_error_db),
                                            within_budget=bool(choice.within_budget), refine=choice.refine,
                                            model_dx=float(choice.model_dx),
                                            interpolant_spread_db=dict(choice.interpolant_spread_db))
            studies.append(choice.study.with_columns(
                pl.lit(name).alias("group"), ((pl.col("dx") == choice.dx) & (pl.col("refine") == choice.refine)
                                              & (pl.col("tol") == choice.tol)).alias("chosen")))
    if not choices:
        fallback = plan_without_budget(runs, options)
        return dataclasses.replace(fallback, source=fallback.source + " (no pilot possible: no run could be read "
                                                                      "and cut into segments)",
                                   failed_pilots=failed, unread_runs={**unread, **fallback.unread_runs}), pl.DataFrame()
    dx = min(c.dx for c in choices)
    tol = min(c.tol for c in choices)
    # the finest model grid any group needs, on the job's data interval
    refine = max(1, int(np.ceil(dx / min(c.model_dx for c in choices) * (1.0 - 1e-9))))
    bands = sorted({b for c in choices for b in c.band_error_db})
    band_error = {b: max(c.band_error_db.get(b, 0.0) for c in choices) for b in bands}
    spread = {b: max(c.interpolant_spread_db[b] for c in choices if b in c.interpolant_spread_db)
              for b in bands if any(b in c.interpolant_spread_db for c in choices)}
    within = all(c.within_budget for c in choices)
    worst = max(c.worst_error_db for c in choices)
    if not within:
        missed = "; ".join(missed_budget(name, g, dx) for name, g in group_errors.items() if not g.within_budget)
        where = (f"in every group at the given dx of {options.dx * 1e3:g} mm" if options.dx is not None
                 else "at the data's sampling of every group")
        warnings.warn(
            f"the error budget of {options.error_budget_db:g} dB cannot be met {where}: "
            f"the smallest estimated error in the tyre/road noise bands is {missed}; the job runs at the cheapest "
            "setting near that floor and states the error of every band (bands.parquet level_error_db)",
            ErrorBudgetWarning, stacklevel=3)
    study = pl.concat(studies, how="diagonal_relaxed")
    per_group = study.group_by("group").agg(
        pl.col("work_per_metre").filter(pl.col("chosen")).max().alias("chosen"),
        pl.col("work_per_metre").filter(pl.col("reference")).max().alias("finest"))
    speedup = float((per_group["finest"] / per_group["chosen"]).min())
    plan = JobPlan(
        dx=float(dx), tol=float(tol), refine=refine, source=f"error budget pilots of {len(choices)} group(s)",
        budget_db=options.error_budget_db, within_budget=within, worst_error_db=float(worst), band_error_db=band_error,
        interpolant_spread_db=spread,
        seconds_per_metre=float(max(c.seconds_per_metre for c in choices)),
        finest_seconds_per_metre=float(max(c.finest_seconds_per_metre for c in choices)), speedup=speedup,
        pilot_seconds=float(sum(c.pilot_seconds for c in choices)), groups=read_runs, group_errors=group_errors,
        failed_pilots=failed, unread_runs=unread)
    return plan, study


def missed_budget(name: str, group: "GroupError", dx: float) -> str:
    """A group's smallest error in the budget bands, in words: "name: 0.4 dB", or, where some
    budget bands are not reported at ``dx`` (m; too coarse to resolve their wavelengths, so no
    error can be stated: an infinite estimate), which bands and the largest error of the others."""
    if np.isfinite(group.worst_error_db):
        return f"{name}: {group.worst_error_db:.3g} dB"
    unreported = sorted(b for b, e in group.band_error_db.items() if not np.isfinite(e))
    finite = [e for e in group.band_error_db.values() if np.isfinite(e)]
    span = nominal_label(unreported[0]) + ("" if len(unreported) == 1 else f" to {nominal_label(unreported[-1])}")
    others = f"; the bands it reports err by up to {max(finite):.3g} dB" if finite else ""
    return (f"{name}: no error can be stated for {len(unreported)} of its budget bands ({span} mm), which dx "
            f"{dx * 1e3:g} mm is too coarse to report{others}")


def plan_without_budget(runs: list[dict[str, Any]], options: ProcessingOptions) -> JobPlan:
    tol = DEFAULT_TOL if options.tol is None else options.tol
    refine = options.refine or 1   # without a budget, the data's own grid unless one is given
    if options.dx is not None:
        return JobPlan(dx=options.dx, tol=tol, refine=refine, source="given")
    unread: dict[str, str] = {}
    read = readable(runs, options, PLAN_SAMPLE_RUNS, unread)
    if not read:
        return JobPlan(dx=0.5e-3, tol=tol, refine=refine, source="ISO 13473-1 grid (no sampled run could be read)",
                       unread_runs=unread)
    return JobPlan(dx=float(min(profile.dx for _, profile in read)), tol=tol, refine=refine,
                   source=f"finest of {len(read)} sampled runs", groups={"all": [run["run_id"] for run, _ in read]},
                   unread_runs=unread)
