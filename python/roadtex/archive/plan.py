"""The job's plan: what the job decided for each run, apart from what the user asked.

:class:`~roadtex.archive.options.ProcessingOptions` is what a user chooses, and stays as given.
The plan (:class:`JobPlan`, made once per job by :func:`roadtex.archive.planning.plan_job`) is
what the job decided from it and from the data:

- **Pilot groups** (:class:`GroupPilot`): with an error budget, a pilot per (device, pavement)
  group and sampling interval measures how the levels converge on a few of the group's segments
  and picks the cheapest data interval, model grid and tolerance within the budget
  (:func:`roadtex.budget.choose_setting`), with the error estimate of every band level.
- **One entry per run** (:class:`RunPlan`, :meth:`JobPlan.line_entry`, :meth:`JobPlan.surface_entry`):
  the interval its readings are solved at (its own, or coarser where its group's pilot chose to
  average fine data down; never finer than its own), its model grid (k times finer than that,
  the run's own readings joined by the interpolant), its tolerance, and where its stated errors
  come from. A run's results depend on its entry, its file and the roadtex version only: the same
  run gets the same tables in any archive whose plan gives it the same entry, and its fingerprint
  (:func:`roadtex.archive.store.run_fingerprint`) is made of exactly those.

Runs of a sampling interval no pilot of their group measured (the pilot reads a few runs of each
group) are solved on the finest model grid any group needs, at the tightest tolerance, and carry
the largest error estimate of any group: their rows say so (``error_source``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roadtex.archive.options import DEFAULT_TOL, ProcessingOptions
from roadtex.archive.reading import group_key

#: Relative slack when comparing sampling intervals read from files (floating-point positions).
SAME_INTERVAL = 1e-9


def spacing_key(dx: float) -> float:
    """A file's interval (m) as its pilot group knows it: two significant digits (0.5 and 0.5004 mm
    are one device's sampling)."""
    return float(f"{dx:.2g}")


@dataclass(frozen=True)
class GroupPilot:
    """One pilot's choice and error estimates, for the runs of its group and sampling interval.

    Attributes:
        name: the group's name in the tables (``"device / pavement"``, ``" @ 0.5 mm"`` added when
            the group holds several samplings).
        key: the (device, pavement) group (:func:`roadtex.archive.reading.group_key`).
        spacing: the group's sampling interval (m, two significant digits: :func:`spacing_key`).
        data_dx: the interval the pilot chose to solve at (m): the runs' own, or coarser (their
            readings averaged down) where that is cheaper within the budget.
        refine: the model grid's refinement k (solved every ``interval / k``).
        tol: the solver tolerance chosen (relative residual).
        band_error_db: band number -> upper estimate (dB) of the numerical error of any level of that
            band at this setting (inf: a band the setting cannot report).
        worst_error_db: the largest of those in the budget bands (dB).
        within_budget: whether that is within the budget.
        interpolant_spread_db: band number -> what the group's sampling cannot tell (dB).
        pilot_runs: the run ids the pilot read.
        seconds_per_metre, finest_seconds_per_metre: measured solve time per metre at the chosen
            setting and at the pilot's reference (s/m); ``work_speedup``: the reference's work over
            the chosen one's (iterations x N log2 N, independent of the machine's load).
        pilot_seconds: the pilot's wall time (s) when it ran.
    """

    name: str
    key: str
    spacing: float
    data_dx: float
    refine: int
    tol: float
    band_error_db: dict[int, float]
    worst_error_db: float
    within_budget: bool
    interpolant_spread_db: dict[int, float] = field(default_factory=dict)
    pilot_runs: tuple[str, ...] = ()
    seconds_per_metre: float = float("nan")
    finest_seconds_per_metre: float = float("nan")
    work_speedup: float = float("nan")
    pilot_seconds: float = 0.0

    @property
    def model_dx(self) -> float:
        """The group's model grid interval (m)."""
        return self.data_dx / self.refine


@dataclass(frozen=True)
class RunPlan:
    """What the job decided for one run: everything its results depend on besides its file.

    Attributes:
        kind: ``"line"`` or ``"surface"``.
        data_dx: the interval the run's readings are solved at (m): its file's own (``None`` for a
            surface: its own spacings), or coarser where its group's pilot chose to average them down.
        refine: the model grid's refinement k (``None``: a surface run's own areal pilot chooses it).
        tol: the solver tolerance (``None``: a surface run's own areal pilot chooses it).
        interpolant: how the readings are joined on the model grid.
        group: the pilot group whose error estimates the run carries (None: none).
        error_source: where the run's stated errors come from, in words (None: no error budget).
    """

    kind: str
    data_dx: float | None
    refine: int | None
    tol: float | None
    interpolant: str
    group: str | None = None
    error_source: str | None = None

    @property
    def model_dx(self) -> float | None:
        """The model grid's interval along the road (m), when the plan fixes it."""
        return None if self.data_dx is None or self.refine is None else self.data_dx / self.refine

    def solved_as(self) -> dict[str, Any]:
        """The fields that change what the run computes (its fingerprint's share of the plan):
        the group and error source only label the estimates joined when the job combines the runs."""
        return {"kind": self.kind, "data_dx": self.data_dx, "refine": self.refine, "tol": self.tol,
                "interpolant": self.interpolant}


@dataclass(frozen=True)
class JobPlan:
    """The job's plan: the user's options and what the job decided from them (see the module docstring).

    Attributes:
        options: what the user asked, as given.
        source: how the plan was made, in words.
        pilots: the pilot groups (empty without an error budget, or where no pilot could run).
        failed_pilots: group name -> why its pilot could not run.
        unread_runs: run id -> why the plan could not use a run it sampled (the run's own
            processing records its failure too).
        reused_pilots: the names of the pilots taken from the output folder's kept plan (not run again).
    """

    options: ProcessingOptions
    source: str
    pilots: tuple[GroupPilot, ...] = ()
    failed_pilots: dict[str, str] = field(default_factory=dict)
    unread_runs: dict[str, str] = field(default_factory=dict)
    reused_pilots: tuple[str, ...] = ()

    @classmethod
    def given(cls, options: ProcessingOptions) -> "JobPlan":
        """The plan of a job without line pilots: each run at its own interval (or ``options.dx`` where
        coarser), ``options.refine`` (1 when None) and ``options.tol`` (:data:`DEFAULT_TOL` when None)."""
        return cls(options=options, source="as given (no pilot)")

    @property
    def budget_db(self) -> float | None:
        return self.options.error_budget_db

    def pilot_of(self, run: dict[str, Any], file_dx: float | None) -> GroupPilot | None:
        """The pilot of a manifest row whose file is sampled every ``file_dx`` m, or None."""
        if file_dx is None or not np.isfinite(file_dx):
            return None
        key, spacing = group_key(run), spacing_key(file_dx)
        return next((p for p in self.pilots if p.key == key and p.spacing == spacing), None)

    def line_entry(self, run: dict[str, Any], file_dx: float) -> RunPlan:
        """The plan of a line run whose file is sampled every ``file_dx`` m (see the module docstring)."""
        options = self.options
        interval = file_dx if options.dx is None else max(file_dx, options.dx)   # never finer than its readings
        pilot = self.pilot_of(run, file_dx)
        if pilot is not None:
            coarsened = pilot.data_dx > file_dx * (1.0 + SAME_INTERVAL)
            return RunPlan(kind="line", data_dx=pilot.data_dx if coarsened else interval, refine=pilot.refine,
                           tol=pilot.tol, interpolant=options.interpolant, group=pilot.name,
                           error_source=f"the pilot of its group ({pilot.name})")
        tol = DEFAULT_TOL if options.tol is None else options.tol
        if options.error_budget_db is None or not self.pilots:
            why = None if options.error_budget_db is None else "no pilot could run: no error estimate"
            return RunPlan(kind="line", data_dx=interval, refine=options.refine or 1, tol=tol,
                           interpolant=options.interpolant, error_source=why)
        # a sampling no pilot of its group measured: the finest model grid and the tightest tol any
        # group needs, and the largest estimate of any group, said so in its rows
        finest = min(p.model_dx for p in self.pilots)
        refine = options.refine or max(1, int(np.ceil(interval / finest * (1.0 - SAME_INTERVAL))))
        return RunPlan(kind="line", data_dx=interval, refine=refine, tol=min(p.tol for p in self.pilots),
                       interpolant=options.interpolant,
                       error_source=(f"no pilot of {group_key(run)} at {file_dx * 1e3:.3g} mm: the finest model grid "
                                     "and the largest estimate of any group"))

    def surface_entry(self) -> RunPlan:
        """The plan of a surface run: its own spacings; with an error budget its own areal pilot
        chooses k and the tolerance unless the user gave them (:mod:`roadtex.archive.surface_run`)."""
        options = self.options
        budget = options.error_budget_db is not None
        refine = options.refine if options.refine is not None or budget else 1
        tol = options.tol if options.tol is not None or budget else DEFAULT_TOL
        return RunPlan(kind="surface", data_dx=None, refine=refine, tol=tol, interpolant=options.interpolant,
                       error_source="its own areal pilot" if budget else None)

    def band_errors(self, entry: RunPlan) -> tuple[dict[int, float], dict[int, float], float | None, bool | None]:
        """A line run's stated errors from its entry: (band -> error dB, band -> interpolant spread
        dB, worst error dB, within budget); the largest of any group where no pilot covered it."""
        if self.budget_db is None or not self.pilots:
            return {}, {}, None, None
        pilot = next((p for p in self.pilots if p.name == entry.group), None)
        if pilot is not None:
            return pilot.band_error_db, pilot.interpolant_spread_db, pilot.worst_error_db, pilot.within_budget
        bands = sorted({b for p in self.pilots for b in p.band_error_db})
        errors = {b: max(p.band_error_db.get(b, 0.0) for p in self.pilots) for b in bands}
        spread = {b: max(p.interpolant_spread_db[b] for p in self.pilots if b in p.interpolant_spread_db)
                  for b in bands if any(b in p.interpolant_spread_db for p in self.pilots)}
        return (errors, spread, max(p.worst_error_db for p in self.pilots),
                all(p.within_budget for p in self.pilots))

    @property
    def worst_error_db(self) -> float | None:
        return max((p.worst_error_db for p in self.pilots), default=None)

    @property
    def within_budget(self) -> bool | None:
        return None if self.budget_db is None or not self.pilots else all(p.within_budget for p in self.pilots)

    @property
    def work_speedup(self) -> float | None:
        """The smallest saving of any pilot: its reference's work over its chosen setting's."""
        finite = [p.work_speedup for p in self.pilots if np.isfinite(p.work_speedup)]
        return min(finite) if finite else None

    def summary(self) -> dict[str, Any]:
        """The plan as JSON-ready values (parameters.json ``plan``; an error a setting cannot state,
        infinite, as null): each pilot group's choice and estimates (``group_errors``, by name; the
        runs each read in ``groups``), their largest errors and smallest saving over the groups."""
        def clean(value: Any) -> Any:
            if isinstance(value, float) and not np.isfinite(value):
                return None
            if isinstance(value, dict):
                return {str(k): clean(v) for k, v in value.items()}
            if isinstance(value, (list, tuple)):
                return [clean(v) for v in value]
            return value
        pilots = self.pilots
        bands = sorted({b for p in pilots for b in p.band_error_db})
        worst_band = {b: max(p.band_error_db.get(b, 0.0) for p in pilots) for b in bands}
        spread = {b: max(p.interpolant_spread_db[b] for p in pilots if b in p.interpolant_spread_db)
                  for b in bands if any(b in p.interpolant_spread_db for p in pilots)}
        return clean({
            "source": self.source, "budget_db": self.budget_db, "within_budget": self.within_budget,
            "worst_error_db": self.worst_error_db, "band_error_db": worst_band, "interpolant_spread_db": spread,
            "speedup": self.work_speedup,
            "seconds_per_metre": max((p.seconds_per_metre for p in pilots), default=None),
            "finest_seconds_per_metre": max((p.finest_seconds_per_metre for p in pilots), default=None),
            "pilot_seconds": sum(p.pilot_seconds for p in pilots if p.name not in self.reused_pilots),
            "groups": {p.name: list(p.pilot_runs) for p in pilots},
            "group_errors": {p.name: {**dataclasses.asdict(p), "model_dx": p.model_dx} for p in pilots},
            "failed_pilots": self.failed_pilots, "unread_runs": self.unread_runs,
            "reused_pilots": list(self.reused_pilots)})
