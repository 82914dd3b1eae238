"""What the bulk job computes: :class:`ProcessingOptions`, checked before any work starts."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field

import numpy as np

from roadtex._checks import (
    PLAUSIBLE_MODULUS,
    PLAUSIBLE_PRESSURE,
    finite_number,
    implausible_parameter,
    poisson_ratio,
    positive,
    positive_int,
)
from roadtex._core import __version__
from roadtex.budget import DEFAULT_ERROR_BUDGET_DB
from roadtex.errors import InvalidInputError
from roadtex.models.grid import DEFAULT_INTERPOLANT, check_interpolant, check_refine
from roadtex.profiles.mpd import estimated_texture_depth
from roadtex.profiles.readers import READ_OPTIONS
from roadtex.profiles.units import unit_factor
from roadtex.spectra.bands import check_band_kind

#: The finest job interval accepted (m): a laser profilometer's spot is tens of micrometres, and
#: a run of metres at 1e-12 m would need terabytes (a unit slip, refused before any work).
MIN_JOB_DX = 1e-6
#: The shortest segment accepted (m): the shortest texture band the job reports is a few mm long.
MIN_SEGMENT_LENGTH = 0.01
#: Solver tolerance without an error budget (relative residual).
DEFAULT_TOL = 1e-6
#: The largest model grid of one line segment (points): 16 MB per array, a few seconds per solve.
#: Beyond it a run is refused naming its segment length, interval and k (the job checks it per run:
#: it depends on the file's interval).
MAX_SEGMENT_MODEL_POINTS = 1 << 21
#: The shortest reporting section (m): one ISO 13473-1:2019 (clause 3.6) MPD baseline of 100 mm.
MIN_SECTION_LENGTH = 0.1
#: The fastest vehicle speed accepted for band frequencies (km/h): faster than any road vehicle whose
#: tyre/road noise is measured (CPX and CPB run at 50 to 110 km/h).
MAX_SPEED_KMH = 400.0
#: The largest share of a segment that the next one may overlap: beyond it the segments step by less
#: than a quarter of their length and the job would solve each stretch of road four times or more.
MAX_OVERLAP_SHARE = 0.75


def check_reader_defaults(defaults: dict[str, object]) -> None:
    """The job-wide reader options whose values can be checked without a file (units, ``dx`` in m,
    the decimal mark): a bad one is refused before any work rather than failing every run."""
    for name in ("distance_unit", "height_unit"):
        if defaults.get(name) is not None:
            unit = defaults[name]
            if not isinstance(unit, str):
                raise InvalidInputError(f"reader_defaults {name} must be a unit name (m, mm, um, ...), got {unit!r}")
            unit_factor(unit, f"reader_defaults {name} (--{name.replace('_', '-')})")
    if defaults.get("dx") is not None:
        positive(defaults["dx"], "reader_defaults dx (--input-dx)", "m")
    if defaults.get("decimal") is not None and defaults["decimal"] not in (".", ","):
        raise InvalidInputError(f"reader_defaults decimal must be '.' or ',', got {defaults['decimal']!r}")


@dataclass(frozen=True)
class ProcessingOptions:
    """What the bulk job computes. All values SI.

    Attributes:
        youngs_moduli: rubber moduli E to solve for (Pa).
        mean_pressure: P, mean contact pressure (Pa).
        poisson: nu of the rubber.
        segment_length: length of the segments handed to the periodic contact model (m).
        segment_overlap: overlap between consecutive segments (m).
        dx: the interval (m) runs sampled more finely are averaged down to (ISO 13473-1's interval
            averaging) before they are solved. None (the default): each run is solved on its own
            readings at its own interval, or at a coarser one where its group's error budget pilot
            finds that cheaper within the budget. A run sampled more coarsely than ``dx`` keeps its
            own readings: no run is resampled onto a grid finer than its own (the model grid,
            ``refine``, is where the solve is finer than the data).
        spike_alpha: spike criterion of the cleaning before the contact model and the spectra: a
            reading at least alpha x 0.5 mm from the median of the readings within 0.5 mm is a
            spike (ISO 13473-1's alpha, on its 0.5 mm grid, whatever the file's sampling; see
            :func:`roadtex.profiles.conditioning.clean`). None: no spike removal.
        mpd_spike_alpha: spike criterion of the mean profile depth, computed after ISO 13473-1 on
            the profile resampled to 0.5 mm (3 in the standard; the CAPTIF authors use 6 on
            coarse chip seals; None skips).
        error_budget_db: the largest numerical error (dB) allowed on any reported level in the
            tyre/road noise bands (see :mod:`roadtex.budget`); a pilot per group of runs picks the
            cheapest interval, model grid and ``tol`` within it (the job's plan,
            :class:`roadtex.archive.plan.JobPlan`), and every band row states its estimated error.
            None switches it off. Default 0.2 dB.
        tol: solver tolerance (relative residual, see :func:`roadtex.contact`). None (the
            default): chosen by the error budget, or :data:`DEFAULT_TOL` without one. 1e-6 of a
            few millimetres of texture is a few nanometres.
            Each segment's moduli are solved in the order given, each from the previous one's
            solution (``contact_many(warm_start=True)``): every result meets ``tol``.
        refine: the model grid's refinement k: the contact model is solved on a grid k times finer
            than the data's (every ``dx / k``), the readings joined by ``interpolant``
            (:mod:`roadtex.models.grid`); texture levels stay those of the data. None (the
            default): chosen by the error budget (1 without one). 1: the data's own grid.
        interpolant: the continuous road between readings, ``"pchip"`` (monotone cubic, the
            default since 0.5.0), ``"linear"`` or ``"bandlimited"``
            (:data:`roadtex.models.grid.INTERPOLANTS`); the pilots solve the same road.
        sampling_correction: subtract from the enveloped levels the bias the run's sampling causes
            where the calibration on real fine data shows a systematic one (e.g. -0.9 dB at 2.5 mm for
            1 mm data, E = 2 MPa; :mod:`roadtex.budget.sampling`); bands.parquet states the correction
            and its uncertainty. Off by default: the levels are then the model's on the data as read.
        max_iterations: solver iteration cap; segments that do not converge are kept and flagged.
        band_kind: "third_octave" or "octave".
        band_method: "dft" (the default: exact DFT band sums, ISO 13473-4's informative method) or
            "filter" (one-third-octave band-pass filters, IEC 61260-1 class 1, the 2024 edition's
            normative method; see :func:`roadtex.spectra.band_levels`).
        speed_kmh: vehicle speed for the band frequencies when the manifest has no ``speed_kmh``.
        keep_profiles: also write the enveloped profiles and pressures (large).
        allow_implausible: the command line's ``--allow-implausible``: (1) process runs whose
            heights or sampling interval cannot be road texture in metres (usually a unit mistake;
            see :func:`roadtex.profiles.plausibility.implausible_texture`) as read, with a warning,
            instead of refusing them; a run whose distance unit is certain (OpenCRG, a unit its
            header states, or ``distance_unit`` given) is never refused for a coarse interval
            alone: it is processed with a :class:`~roadtex.errors.CoarseSamplingWarning`, its
            unresolved bands not reported; (2) solve moduli outside 0.1 to 100 MPa and pressures
            outside 0.02 to 3 MPa (given in Pa), which are refused by default (MPa given as Pa is
            the usual cause). Not part of the fingerprint: it changes nothing a processed run
            computes (a run it refused stays on record as failed until ``--retry-failed``).
        section_length: length of the reporting sections of line runs (m; sections.parquet,
            :mod:`roadtex.archive.sections`); 10 m by default, 20 m and 100 m are common.
        etd_edition: the ISO 13473-1 edition whose MPD-to-ETD transformation sections.parquet's
            ETD follows ("2019": 1.1 MPD; "1997": 0.2 mm + 0.8 MPD).
        reader_defaults: :func:`roadtex.read_profile` options for every run (``distance_unit``,
            ``height_unit``, ``delimiter``, ``decimal``, ``dx`` in m, ...); manifest columns of the
            same names override them per run.
    """

    youngs_moduli: tuple[float, ...] = (1e6, 2e6, 5e6, 1e7)
    mean_pressure: float = 2e5
    poisson: float = 0.5
    segment_length: float = 0.5
    segment_overlap: float = 0.0
    dx: float | None = None
    spike_alpha: float | None = 3.0
    mpd_spike_alpha: float | None = 3.0
    error_budget_db: float | None = DEFAULT_ERROR_BUDGET_DB
    tol: float | None = None
    refine: int | None = None
    interpolant: str = DEFAULT_INTERPOLANT
    sampling_correction: bool = False
    max_iterations: int = 2000
    band_kind: str = "third_octave"
    band_method: str = "dft"
    speed_kmh: float | None = None
    keep_profiles: bool = False
    allow_implausible: bool = False
    reader_defaults: dict[str, object] = field(default_factory=dict)
    section_length: float = 10.0
    etd_edition: str = "2019"

    def __post_init__(self) -> None:
        moduli = tuple(positive(e, "youngs_moduli", "Pa") for e in np.atleast_1d(self.youngs_moduli))
        if not moduli:
            raise InvalidInputError("youngs_moduli must name at least one modulus (Pa)")
        repeated = sorted({e for e in moduli if moduli.count(e) > 1})
        if repeated:
            # each modulus is a set of rows; a repeated one would duplicate them (and the sampling
            # statement joined per modulus), which no average over the rows should count twice
            raise InvalidInputError(f"youngs_moduli lists {', '.join(f'{e:g} Pa' for e in repeated)} more than once: "
                                    "give each modulus once")
        object.__setattr__(self, "youngs_moduli", moduli)
        object.__setattr__(self, "mean_pressure", positive(self.mean_pressure, "mean_pressure", "Pa"))
        object.__setattr__(self, "segment_length", positive(self.segment_length, "segment_length", "m"))
        if self.segment_length < MIN_SEGMENT_LENGTH:
            raise InvalidInputError(f"segment_length = {self.segment_length:g} m is shorter than {MIN_SEGMENT_LENGTH:g} m: "
                                    "no segment could hold a texture wavelength the job reports (is it in the wrong "
                                    "unit? it is in metres, e.g. 0.5)")
        if self.tol is not None:
            object.__setattr__(self, "tol", positive(self.tol, "tol", "relative residual"))
            if self.tol >= 1.0:
                raise InvalidInputError(f"tol must be below 1 (a relative residual, e.g. 1e-6), got {self.tol!r}: "
                                        "a residual of 1 or more is no solution")
        if self.error_budget_db is not None:
            object.__setattr__(self, "error_budget_db", positive(self.error_budget_db, "error_budget_db", "dB"))
        object.__setattr__(self, "poisson", poisson_ratio(self.poisson))
        object.__setattr__(self, "max_iterations", positive_int(self.max_iterations, "max_iterations"))
        if self.dx is not None:
            object.__setattr__(self, "dx", positive(self.dx, "dx", "m"))
            if self.dx < MIN_JOB_DX:
                raise InvalidInputError(f"dx = {self.dx:g} m is finer than {MIN_JOB_DX:g} m (1 um), finer than any "
                                        "texture profilometer samples: is it in the wrong unit? dx is in metres "
                                        "(0.5 mm is 0.5e-3)")
        if self.refine is not None:
            object.__setattr__(self, "refine", check_refine(self.refine))   # at most MAX_REFINE
        check_interpolant(self.interpolant)
        if not isinstance(self.sampling_correction, (bool, np.bool_)):
            raise InvalidInputError(f"sampling_correction must be True or False, got {self.sampling_correction!r}")
        object.__setattr__(self, "sampling_correction", bool(self.sampling_correction))
        overlap = finite_number(self.segment_overlap, "segment_overlap")
        if not 0.0 <= overlap <= MAX_OVERLAP_SHARE * self.segment_length:
            raise InvalidInputError(
                f"segment_overlap = {self.segment_overlap!r} m: it must be between 0 and {MAX_OVERLAP_SHARE:g} of "
                f"segment_length ({MAX_OVERLAP_SHARE * self.segment_length:g} m for segments of {self.segment_length:g} m), "
                "so that consecutive segments step by at least a quarter of their length")
        object.__setattr__(self, "segment_overlap", overlap)
        for name, unit in (("spike_alpha", "a slope, no unit"), ("mpd_spike_alpha", "a slope, no unit"),
                           ("speed_kmh", "km/h")):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, positive(value, name, unit))
        check_band_kind(self.band_kind)
        object.__setattr__(self, "section_length", positive(self.section_length, "section_length", "m"))
        if self.section_length < MIN_SECTION_LENGTH:
            raise InvalidInputError(f"section_length = {self.section_length:g} m is shorter than one ISO 13473-1 MPD "
                                    f"baseline ({MIN_SECTION_LENGTH:g} m), so no section could hold an MPD (it is in "
                                    "metres: 10 m sections are 10)")
        if self.speed_kmh is not None and self.speed_kmh > MAX_SPEED_KMH:
            raise InvalidInputError(f"speed_kmh = {self.speed_kmh:g} km/h is faster than any road vehicle (at most "
                                    f"{MAX_SPEED_KMH:g} km/h accepted; CPX and CPB measure at 50 to 110 km/h)")
        estimated_texture_depth(0.0, self.etd_edition)   # refuses an unknown edition
        if self.band_method not in ("dft", "filter"):
            raise InvalidInputError(f"band_method must be 'dft' or 'filter', got {self.band_method!r}")
        unknown = set(self.reader_defaults) - set(READ_OPTIONS)
        if unknown:
            raise InvalidInputError(f"reader_defaults has unknown option(s) {sorted(unknown)}; known: {sorted(READ_OPTIONS)}")
        object.__setattr__(self, "reader_defaults", {k: v for k, v in sorted(self.reader_defaults.items()) if v is not None})
        check_reader_defaults(self.reader_defaults)
        reasons = [implausible_parameter(e, "youngs_moduli", PLAUSIBLE_MODULUS) for e in moduli]
        reasons.append(implausible_parameter(self.mean_pressure, "mean_pressure", PLAUSIBLE_PRESSURE))
        if any(reasons) and not self.allow_implausible:
            # one refusal before any work, as the command line's: a warning per value, and again per
            # run, went unread while the job wrote normal-looking tables (contact fraction 1.0)
            raise InvalidInputError(
                f"{'; '.join(r for r in reasons if r)} ProcessingOptions takes SI units (Pa: youngs_moduli="
                "(1e6, 2e6, 5e6, 1e7), mean_pressure=2e5); allow_implausible=True solves them anyway (the command "
                "line's --allow-implausible)")

    def fingerprint(self) -> str:
        """SHA-256 of the options and the roadtex version. A run's own fingerprint adds its plan entry
        and its file (:func:`roadtex.archive.store.run_fingerprint`). ``allow_implausible`` is left
        out: it changes no result of a run that was processed (a run it refused stays on record as
        failed until retried, ``--retry-failed``)."""
        options = {k: v for k, v in dataclasses.asdict(self).items() if k != "allow_implausible"}
        payload = json.dumps({"options": options, "roadtex": __version__}, sort_keys=True)
        return hashlib.sha256(payload.encode()).hexdigest()
