"""What the bulk job computes: :class:`ProcessingOptions`, checked before any work starts."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass

import numpy as np

from roadtex._checks import finite_number, poisson_ratio, positive, positive_int
from roadtex._core import __version__
from roadtex.errors import InvalidInputError
from roadtex.spectra.bands import check_band_kind


@dataclass(frozen=True)
class ProcessingOptions:
    """What the bulk job computes. All values SI.

    Attributes:
        youngs_moduli: rubber moduli E to solve for (Pa).
        mean_pressure: P, mean contact pressure (Pa).
        poisson: nu of the rubber.
        segment_length: length of the segments handed to the periodic contact model (m).
        segment_overlap: overlap between consecutive segments (m).
        dx: resample every run to this sampling interval (m); None keeps the file's sampling.
        spike_alpha: spike criterion alpha of the conditioning for the contact model (None: no
            spike removal). It compares adjacent samples, so it means what ISO 13473-1 means
            only at 0.5 to 1 mm sampling; at finer sampling leave it off or raise it.
        mpd_spike_alpha: spike criterion of the mean profile depth, computed after ISO 13473-1 on
            the profile resampled to 0.5 mm (3 in the standard; the CAPTIF authors use 6 on
            coarse chip seals; None skips).
        tol: solver tolerance (relative residual, see :func:`roadtex.contact`). 1e-6 of a few
            millimetres of texture is a few nanometres, far below what the spectra resolve.
            Each segment's moduli are solved in the order given, each from the previous one's
            solution (``contact_many(warm_start=True)``): every result meets ``tol``.
        max_iterations: solver iteration cap; segments that do not converge are kept and flagged.
        band_kind: "third_octave" or "octave".
        speed_kmh: vehicle speed for the band frequencies when the manifest has no ``speed_kmh``.
        keep_profiles: also write the enveloped profiles and pressures (large).
    """

    youngs_moduli: tuple[float, ...] = (1e6, 2e6, 5e6, 1e7)
    mean_pressure: float = 2e5
    poisson: float = 0.5
    segment_length: float = 0.5
    segment_overlap: float = 0.0
    dx: float | None = None
    spike_alpha: float | None = None
    mpd_spike_alpha: float | None = 3.0
    tol: float = 1e-6
    max_iterations: int = 2000
    band_kind: str = "third_octave"
    speed_kmh: float | None = None
    keep_profiles: bool = False

    def __post_init__(self) -> None:
        moduli = tuple(positive(e, "youngs_moduli", "Pa") for e in np.atleast_1d(self.youngs_moduli))
        if not moduli:
            raise InvalidInputError("youngs_moduli must name at least one modulus (Pa)")
        object.__setattr__(self, "youngs_moduli", moduli)
        object.__setattr__(self, "mean_pressure", positive(self.mean_pressure, "mean_pressure", "Pa"))
        object.__setattr__(self, "segment_length", positive(self.segment_length, "segment_length", "m"))
        object.__setattr__(self, "tol", positive(self.tol, "tol", "relative residual"))
        object.__setattr__(self, "poisson", poisson_ratio(self.poisson))
        object.__setattr__(self, "max_iterations", positive_int(self.max_iterations, "max_iterations"))
        if self.dx is not None:
            object.__setattr__(self, "dx", positive(self.dx, "dx", "m"))
        overlap = finite_number(self.segment_overlap, "segment_overlap")
        if not 0.0 <= overlap < self.segment_length:
            raise InvalidInputError(f"segment_overlap must be in [0, segment_length) (m), got {self.segment_overlap!r}")
        for name, unit in (("spike_alpha", "a slope, no unit"), ("mpd_spike_alpha", "a slope, no unit"),
                           ("speed_kmh", "km/h")):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, positive(value, name, unit))
        check_band_kind(self.band_kind)

    def fingerprint(self) -> str:
        """SHA-256 of the options and the roadtex version: equal fingerprints give equal results."""
        payload = json.dumps({"options": dataclasses.asdict(self), "roadtex": __version__}, sort_keys=True)
        return hashlib.sha256(payload.encode()).hexdigest()
