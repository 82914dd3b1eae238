"""Tyre/road contact on a line profile: the public solver API and its result types.

Units are SI: heights and dx in metres, moduli and pressures in pascals.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Iterator, Literal, Sequence

import numpy as np

from roadtex import _core
from roadtex._checks import as_float_array, positive_int, to_float

Kernel = Literal["element", "spectral"]
Method = Literal["cg", "direct"]


class ConvergenceError(RuntimeError):
    """The solver stopped at ``max_iterations`` before reaching ``tol``."""


class RoadtexWarning(UserWarning):
    """Base class of the warnings roadtex gives about input it accepts but doubts."""


class ImplausibleTextureWarning(RoadtexWarning):
    """The heights are implausible for a road texture profile in metres (given in mm by mistake?).

    The solve goes ahead as asked; see :data:`PLAUSIBLE_PEAK_TO_VALLEY`, :data:`PLAUSIBLE_RMS` and
    :data:`PLAUSIBLE_MEDIAN_SLOPE` for when it is raised.
    """


#: Peak-to-valley height (m) of a profile, its least-squares line removed, above which
#: :func:`contact` warns. Road texture, megatexture included (wavelengths up to 0.5 m), has
#: amplitudes of 0.1 to 50 mm (ISO 13473-1); a texture profile written in millimetres shows 1 to 50.
PLAUSIBLE_PEAK_TO_VALLEY = 1.0
#: rms height (m), least-squares line removed, above which :func:`contact` warns (same reason).
PLAUSIBLE_RMS = 0.25
#: Median |dz/dx| above which :func:`contact` warns: half the profile steeper than 87 degrees. Road
#: texture has median slopes well under 1 (pore walls and chip edges are few); heights in mm on a
#: grid in m have slopes 1000 times the true ones, which also catches fine textures in mm.
PLAUSIBLE_MEDIAN_SLOPE = 20.0


def _warn_if_implausible(heights: np.ndarray, dx: float, name: str) -> None:
    """Warns (ImplausibleTextureWarning) when any row of ``heights`` (m) cannot be a road profile.

    Looks at each row with its least-squares line removed. Rows with NaN or inf are left to the
    input checks of the solver.
    """
    rows = np.atleast_2d(heights)
    n = rows.shape[1]
    if rows.size == 0 or n < 2 or not (np.isfinite(dx) and dx > 0):
        return
    with np.errstate(all="ignore"):
        x = np.arange(n) - 0.5 * (n - 1)
        centred = rows - rows.mean(axis=1, keepdims=True)
        detrended = centred - np.outer(centred @ x / (x @ x), x)
        peak_to_valley = detrended.max(axis=1) - detrended.min(axis=1)
        rms = np.sqrt(np.mean(detrended**2, axis=1))
        median_slope = np.median(np.abs(np.diff(rows, axis=1)), axis=1) / dx
        bad = ((peak_to_valley > PLAUSIBLE_PEAK_TO_VALLEY) | (rms > PLAUSIBLE_RMS)
               | (median_slope > PLAUSIBLE_MEDIAN_SLOPE))
    if not bad.any():
        return
    first = int(np.argmax(bad))
    where = f"{name} (segment {first}, {int(bad.sum())} of {bad.size} segments)" if heights.ndim == 2 else name
    warnings.warn(
        f"{where}: peak-to-valley {peak_to_valley[first]:.3g} m, rms {rms[first]:.3g} m (linear trend removed) "
        f"and median slope {median_slope[first]:.3g} are implausible for a road texture profile "
        f"(roadtex warns above {PLAUSIBLE_PEAK_TO_VALLEY:g} m, {PLAUSIBLE_RMS:g} m and {PLAUSIBLE_MEDIAN_SLOPE:g}). "
        "Heights and dx must be in metres: were the heights given in millimetres? Solving as given.",
        ImplausibleTextureWarning, stacklevel=3)


class ContactMeasures:
    """What every contact model's result derives from its pressure and envelope.

    Mixed into :class:`ContactResult` and :class:`roadtex.clapp.ClappResult`, which carry
    ``heights``, ``pressure``, ``envelope`` (m, Pa, m), ``youngs_modulus`` (Pa) and ``poisson``.
    """

    @property
    def in_contact(self) -> np.ndarray:
        """Boolean mask of elements carrying pressure."""
        return self.pressure > 0.0

    @property
    def contact_fraction(self) -> float:
        """Share of the sample length in contact (0..1)."""
        return float(np.count_nonzero(self.pressure > 0.0) / self.pressure.size)

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

    def __iter__(self) -> Iterator[ContactResult]:
        """Results segment by segment, each segment for every modulus in the order given."""
        for segment in range(self.shape[0]):
            for modulus in range(self.shape[1]):
                yield self[segment, modulus]


def contact(
    heights: np.ndarray | Sequence[float],
    dx: float,
    youngs_modulus: float,
    mean_pressure: float,
    *,
    poisson: float = 0.5,
    periodic: bool = True,
    kernel: Kernel = "element",
    method: Method = "cg",
    tol: float = 1e-10,
    max_iterations: int = 2000,
    raise_on_nonconvergence: bool = True,
) -> ContactResult:
    """Presses an elastic half-space (the tyre rubber) onto a rigid road profile.

    Args:
        heights: profile heights z (m), positive up, on N >= 8 equal elements.
        dx: element width (m); the sample length is L = N dx.
        youngs_modulus: E of the rubber (Pa), e.g. 2.5e6.
        mean_pressure: P, the mean contact pressure over L (Pa), e.g. 2e5.
        poisson: nu in (-1, 0.5]; E* = E / (1 - nu^2).
        periodic: True (default) repeats the sample infinitely (the INRETS periodic model);
            False treats it as a finite sample (edge over-pressures).
        kernel: "element" (exact influence coefficients of piecewise-constant pressure) or
            "spectral" (the continuous kernel 2 / (E* |k|) at the discrete wavenumbers).
        method: "cg" (preconditioned constrained conjugate gradients, any N) or "direct"
            (dense active-set solve, N <= 8192, the independent check).
        tol: stop when the worst open gap on the contact set and the worst penetration off it
            are both at most ``tol`` times the profile's peak-to-valley height.
        max_iterations: cap on solver iterations.
        raise_on_nonconvergence: raise :class:`ConvergenceError` when ``tol`` is not reached
            (default); with False the result is returned with ``converged=False``.

    Returns:
        A :class:`ContactResult`.

    Raises:
        ValueError: bad input, with the argument and the problem named.
        ConvergenceError: see ``raise_on_nonconvergence``.

    Warns:
        ImplausibleTextureWarning: the heights cannot be a road texture profile in metres
            (peak-to-valley above 1 m, rms above 0.25 m, or median slope above 20, linear trend
            removed): probably millimetres. The problem is still solved as given.
    """
    z = as_float_array(heights, "heights", 1)
    dx_f, e_f, p_f, nu_f = (to_float(dx, "dx"), to_float(youngs_modulus, "youngs_modulus"),
                            to_float(mean_pressure, "mean_pressure"), to_float(poisson, "poisson"))
    _warn_if_implausible(z, dx_f, "heights")
    pressure, envelope, iterations, residual, converged = _core.solve(
        z, dx_f, e_f, nu_f, p_f, bool(periodic), kernel, method, to_float(tol, "tol"),
        positive_int(max_iterations, "max_iterations"),
    )
    if raise_on_nonconvergence and not converged:
        raise ConvergenceError(
            f"contact solver stopped after {iterations} iterations at residual {residual:.3g} > tol {tol:g}; "
            "raise max_iterations or tol, or pass raise_on_nonconvergence=False"
        )
    return ContactResult(z, dx_f, pressure, envelope, iterations, residual, converged, e_f, nu_f, p_f)


def contact_many(
    segments: np.ndarray | Sequence[Sequence[float]],
    dx: float,
    youngs_modulus: float | Sequence[float] | np.ndarray,
    mean_pressure: float,
    *,
    poisson: float = 0.5,
    periodic: bool = True,
    kernel: Kernel = "element",
    method: Method = "cg",
    tol: float = 1e-10,
    max_iterations: int = 2000,
    threads: int | None = None,
    warm_start: bool = False,
    raise_on_nonconvergence: bool = True,
) -> ContactBatch:
    """Solves :func:`contact` for every segment (row) and every modulus, in parallel.

    The kernel and FFT plans are built once; the (segment, modulus) problems run on a Rust thread
    pool with the GIL released. Each result is bitwise identical to a one-by-one :func:`contact`
    call, whatever the thread count.

    Args:
        segments: 2-D array of heights (m), one segment of N points per row.
        youngs_modulus: one E or a sequence of E values (Pa).
        threads: worker threads; None uses all cores (or RAYON_NUM_THREADS).
        warm_start: solve each segment's moduli in the order given, each CG solve starting from
            the previous modulus's solution (its contact set is close): fewer iterations. Results
            then meet ``tol`` as usual but are no longer bitwise those of one-by-one calls (they
            stay bitwise the same whatever the thread count). Ignored by ``method="direct"``.
        Other arguments: as for :func:`contact`.

    Returns:
        A :class:`ContactBatch` indexed ``[segment, modulus]``.
    """
    heights = as_float_array(segments, "segments", 2)
    moduli = np.atleast_1d(np.asarray(youngs_modulus, dtype=np.float64))
    if moduli.ndim != 1:
        raise ValueError(f"youngs_modulus must be a number or a 1-D sequence, got shape {moduli.shape}")
    threads = None if threads is None else positive_int(threads, "threads")
    dx_f, p_f, nu_f = to_float(dx, "dx"), to_float(mean_pressure, "mean_pressure"), to_float(poisson, "poisson")
    _warn_if_implausible(heights, dx_f, "segments")
    pressure, envelope, iterations, residual, converged = _core.solve_many(
        heights, dx_f, np.ascontiguousarray(moduli), nu_f, p_f, bool(periodic), kernel, method,
        to_float(tol, "tol"), positive_int(max_iterations, "max_iterations"), threads, bool(warm_start),
    )
    if raise_on_nonconvergence and not converged.all():
        bad = np.argwhere(~converged)
        raise ConvergenceError(
            f"{len(bad)} of {converged.size} problems did not reach tol {tol:g} "
            f"(first: segment {bad[0][0]}, modulus {moduli[bad[0][1]]:g} Pa, residual {residual[tuple(bad[0])]:.3g})"
        )
    return ContactBatch(heights, dx_f, moduli, nu_f, p_f, pressure, envelope, iterations, residual, converged)
