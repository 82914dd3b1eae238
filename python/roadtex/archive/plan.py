"""The job's plan: one sampling interval (and solver tolerance) for every run, chosen before any run
is processed.

Results of the contact model depend on the sampling interval (the rubber bridges what it cannot
resolve), so two devices measuring the same road at 0.04 and 0.5 mm would give different contact
fractions if each run kept its own. The job therefore solves every run at one interval: the one
given (``ProcessingOptions.dx``), or else the finest nominal interval among a sample of the runs
(every run of a small archive; :data:`PLAN_SAMPLE_RUNS` spread over a large one). Runs sampled
more coarsely than that are interpolated to it; runs sampled more finely are averaged down.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roadtex.archive.options import ProcessingOptions
from roadtex.errors import RoadtexWarning
from roadtex.profiles.readers import READ_OPTIONS, read_profile

#: Runs read to plan a large archive (spread evenly over the manifest).
PLAN_SAMPLE_RUNS = 8


@dataclass(frozen=True)
class JobPlan:
    """What the job solves every run at.

    Attributes:
        dx: sampling interval (m).
        tol: solver tolerance (relative residual).
        source: how ``dx`` was chosen ("given", or "finest of N sampled runs").
        sampled_runs: run ids read to choose it.
        band_error_db: per band number, an upper estimate of the numerical error of the band
            levels (dB); empty when not estimated.
    """

    dx: float
    tol: float
    source: str
    sampled_runs: tuple[str, ...] = ()
    band_error_db: dict[int, float] = field(default_factory=dict)

    def resolved(self, options: ProcessingOptions) -> ProcessingOptions:
        """``options`` with the plan's interval and tolerance filled in (what the runs are solved with)."""
        import dataclasses

        return dataclasses.replace(options, dx=self.dx, tol=self.tol)


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


def sample_runs(runs: list[dict[str, Any]], count: int = PLAN_SAMPLE_RUNS) -> list[dict[str, Any]]:
    """Up to ``count`` runs spread evenly over ``runs`` (all of them when there are few)."""
    if len(runs) <= count:
        return list(runs)
    picks = np.unique(np.linspace(0, len(runs) - 1, count).round().astype(int))
    return [runs[i] for i in picks]


def plan_job(runs: list[dict[str, Any]], options: ProcessingOptions) -> JobPlan:
    """Chooses the job's sampling interval and tolerance (see the module docstring).

    A sampled run that cannot be read is skipped here (its own processing records why); if none can
    be read, the plan falls back to 0.5 mm, ISO 13473-1's grid.
    """
    if options.dx is not None:
        return JobPlan(dx=options.dx, tol=options.tol, source="given")
    intervals, names = [], []
    for run in sample_runs(runs):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RoadtexWarning)
                profile = read_profile(run["path"], format=run.get("format"), **reader_options(run, options))
        except Exception:  # noqa: BLE001 - the run's own processing records the failure
            continue
        intervals.append(profile.dx)
        names.append(run["run_id"])
    if not intervals:
        return JobPlan(dx=0.5e-3, tol=options.tol, source="ISO 13473-1 grid (no sampled run could be read)")
    return JobPlan(dx=float(min(intervals)), tol=options.tol,
                   source=f"finest of {len(names)} sampled runs", sampled_runs=tuple(names))
