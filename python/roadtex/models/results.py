"""What the contact models return: one result, a batch indexed [segment, modulus], and the
measures derived from pressure and envelope (one implementation, used by the bulk job too)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

#: The measures :func:`contact_measures` gives, with their units.
MEASURE_UNITS = {"contact_fraction": "1", "mean_penetration": "m", "max_penetration": "m", "mean_gap": "m",
                 "max_pressure": "Pa"}


def contact_measures(heights: np.ndarray, pressure: np.ndarray, envelope: np.ndarray) -> dict[str, np.ndarray]:
    """Scalar measures of solved contact problems, over the last axis.

    Args:
        heights: (..., n) road heights (m), broadcast against ``pressure`` and ``envelope``.
        pressure: (..., n) contact pressure (Pa).
        envelope: (..., n) rubber surface (m).

    Returns:
        ``contact_fraction`` (share of elements with p > 0), ``mean_penetration`` and
        ``max_penetration`` (m: how far the rubber surface lies below the highest point of the
        road, on average and at most), ``mean_gap`` (m: rubber surface above the road, the
        texture left unfilled) and ``max_pressure`` (Pa), each of shape (...).
    """
    top = np.max(heights, axis=-1, keepdims=True)
    penetration = top - envelope
    return {
        "contact_fraction": np.mean(pressure > 0.0, axis=-1),
        "mean_penetration": penetration.mean(axis=-1),
        "max_penetration": penetration.max(axis=-1),
        "mean_gap": (envelope - heights).mean(axis=-1),
        "max_pressure": pressure.max(axis=-1),
    }


class ContactMeasures:
    """What every contact model's result derives from its pressure and envelope.

    Mixed into :class:`ContactResult` and :class:`roadtex.models.clapp.ClappResult`, which carry
    ``heights``, ``pressure``, ``envelope`` (m, Pa, m), ``youngs_modulus`` (Pa) and ``poisson``.
    """

    @property
    def in_contact(self) -> np.ndarray:
        """Boolean mask of elements carrying pressure."""
        return self.pressure > 0.0

    @property
    def contact_fraction(self) -> float:
        """Share of the sample length in contact (0..1)."""
        return float(contact_measures(self.heights, self.pressure, self.envelope)["contact_fraction"])

    @property
    def depth_below_envelope(self) -> np.ndarray:
        """envelope - heights (m): how far the rubber stays above the road, 0 on contact."""
        return self.envelope - self.heights

    @property
    def plane_strain_modulus(self) -> float:
        """E* = E / (1 - nu^2) (Pa)."""
        return self.youngs_modulus / (1.0 - self.poisson**2)


@dataclass(frozen=True)
class ContactResult(ContactMeasures):
    """One solved contact problem.

    Attributes:
        heights: the road profile z (m), as given.
        dx: element width (m).
        pressure: element pressures p (Pa), >= 0, mean equal to ``mean_pressure``.
        envelope: the rubber surface, the enveloped profile (m): >= heights, == heights on contact.
        iterations: solver iterations (CG steps; active-set sweeps for ``method="direct"``).
        residual: the achieved residual: the worst open gap on the contact set or penetration
            off it, relative to the profile's peak-to-valley height.
        converged: whether ``residual <= tol``.
        youngs_modulus, poisson, mean_pressure: the rubber and load (Pa, -, Pa).
    """

    heights: np.ndarray
    dx: float
    pressure: np.ndarray
    envelope: np.ndarray
    iterations: int
    residual: float
    converged: bool
    youngs_modulus: float
    poisson: float
    mean_pressure: float


@dataclass(frozen=True)
class ContactBatch:
    """Results of :func:`contact_many`, indexed ``[segment, modulus]``.

    Array attributes have shape (segments, moduli, points) or (segments, moduli).
    """

    heights: np.ndarray
    dx: float
    youngs_moduli: np.ndarray
    poisson: float
    mean_pressure: float
    pressure: np.ndarray
    envelope: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    converged: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        """(number of segments, number of moduli)."""
        return (self.pressure.shape[0], self.pressure.shape[1])

    def __len__(self) -> int:
        return self.shape[0] * self.shape[1]

    def __getitem__(self, index: tuple[int, int]) -> ContactResult:
        segment, modulus = index
        return ContactResult(
            heights=self.heights[segment],
            dx=self.dx,
            pressure=self.pressure[segment, modulus],
            envelope=self.envelope[segment, modulus],
            iterations=int(self.iterations[segment, modulus]),
            residual=float(self.residual[segment, modulus]),
            converged=bool(self.converged[segment, modulus]),
            youngs_modulus=float(self.youngs_moduli[modulus]),
            poisson=self.poisson,
            mean_pressure=self.mean_pressure,
        )

    def measures(self) -> dict[str, np.ndarray]:
        """:func:`contact_measures` of every problem, each of shape (segments, moduli)."""
        return contact_measures(self.heights[:, None, :], self.pressure, self.envelope)

    def __iter__(self) -> Iterator[ContactResult]:
        """Results segment by segment, each segment for every modulus in the order given."""
        for segment in range(self.shape[0]):
            for modulus in range(self.shape[1]):
                yield self[segment, modulus]
