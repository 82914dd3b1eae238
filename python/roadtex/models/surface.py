"""Tyre/road contact on a 3-D road surface (areal contact): the public solver API.

Heights are indexed ``[iy, ix]``: rows run across the road (y, spacing dy), columns along it (x,
spacing dx), as line profiles do. Units are SI: heights, dx and dy in metres, moduli and pressures
in pascals. The rubber is an elastic half-space (Boussinesq); pressure is uniform on each dx x dy
element and the surface is periodic in both directions (or a finite sample).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator, Sequence

import numpy as np

from roadtex import _core
from roadtex._checks import (
    as_float_array,
    moduli_array,
    positive_int,
    spacing_of,
    thread_count,
    to_float,
    warn_if_implausible_rubber,
)
from roadtex.errors import ConvergenceError, InvalidInputError
from roadtex.models.contact import Kernel, Method, checked_initial_pressure
from roadtex.profiles.plausibility import warn_if_implausible_texture
from roadtex.surfaces.surface import Surface


@dataclass(frozen=True)
class SurfaceResult:
    """One solved areal contact problem.

    Attributes:
        heights: the road surface z[iy, ix] (m), as given.
        dx, dy: element sizes along (x, columns) and across (y, rows) the road (m).
        pressure: element pressures p[iy, ix] (Pa), >= 0, mean equal to ``mean_pressure``.
        envelope: the rubber surface (m): >= heights, == heights on contact.
        iterations: solver iterations (CG steps; active-set sweeps for ``method="direct"``).
        residual: the worst open gap on the contact set or penetration off it, relative to the
            surface's peak-to-valley height.
        converged: whether ``residual <= tol``.
        youngs_modulus, poisson, mean_pressure: the rubber and load (Pa, -, Pa).
    """

    heights: np.ndarray
    dx: float
    dy: float
    pressure: np.ndarray
    envelope: np.ndarray
    iterations: int
    residual: float
    converged: bool
    youngs_modulus: float
    poisson: float
    mean_pressure: float

    @property
    def in_contact(self) -> np.ndarray:
        """Boolean mask [iy, ix] of elements carrying pressure."""
        return self.pressure > 0.0

    @property
    def contact_fraction(self) -> float:
        """Share of the surface area in contact (0..1)."""
        return float(np.mean(self.pressure > 0.0))

    @property
    def plane_strain_modulus(self) -> float:
        """E* = E / (1 - nu^2) (Pa)."""
        return self.youngs_modulus / (1.0 - self.poisson**2)


@dataclass(frozen=True)
class SurfaceBatch:
    """Results of :func:`contact_surface_many`, indexed ``[tile, modulus]``.

    ``pressure`` and ``envelope`` have shape (tiles, moduli, ny, nx); ``iterations``,
    ``residual`` and ``converged`` (tiles, moduli).
    """

    heights: np.ndarray
    dx: float
    dy: float
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
        """(number of tiles, number of moduli)."""
        return (self.pressure.shape[0], self.pressure.shape[1])

    def __getitem__(self, index: tuple[int, int]) -> SurfaceResult:
        tile, modulus = index
        return SurfaceResult(self.heights[tile], self.dx, self.dy, self.pressure[tile, modulus],
                             self.envelope[tile, modulus], int(self.iterations[tile, modulus]),
                             float(self.residual[tile, modulus]), bool(self.converged[tile, modulus]),
                             float(self.youngs_moduli[modulus]), self.poisson, self.mean_pressure)

    def __iter__(self) -> Iterator[SurfaceResult]:
        """Results tile by tile, each tile for every modulus in the order given."""
        for tile in range(self.shape[0]):
            for modulus in range(self.shape[1]):
                yield self[tile, modulus]


def _spacings(dx: float, dy: float | None) -> tuple[float, float]:
    dx_f = to_float(dx, "dx")
    return dx_f, dx_f if dy is None else to_float(dy, "dy")


def contact_surface(
    heights: Surface | np.ndarray | Sequence[Sequence[float]],
    dx: float | None = None,
    dy: float | None = None,
    *,
    youngs_modulus: float,
    mean_pressure: float,
    poisson: float = 0.5,
    tol: float = 1e-10,
    periodic: bool = True,
    kernel: Kernel = "element",
    method: Method = "cg",
    max_iterations: int = 2000,
    raise_on_nonconvergence: bool = True,
) -> SurfaceResult:
    """Presses an elastic half-space (the tyre rubber) onto a rigid road surface.

    Args:
        heights: surface heights z[iy, ix] (m), positive up: rows across the road (y), columns
            along it (x); at least 4 points each way. Or a :class:`~roadtex.Surface` (no
            drop-outs), which carries its dx and dy.
        dx: element size along the road, between columns (m); required with an array (with a
            Surface it may be left out; given, it must be the Surface's).
        dy: element size across the road, between rows (m); None takes dx (an array) or the
            Surface's dy.
        youngs_modulus: E of the rubber (Pa), e.g. 2.5e6.
        mean_pressure: P, the mean contact pressure over the surface (Pa), e.g. 2e5.
        poisson: nu in (-1, 0.5]; E* = E / (1 - nu^2).
        tol: stop when the worst open gap on the contact set and the worst penetration off it
            are both at most ``tol`` times the surface's peak-to-valley height (as for
            :func:`roadtex.contact`).
        periodic: True (default) repeats the surface in both directions; False treats it as a
            finite sample (a rigid road patch on an infinite half-space).
        kernel: "element" (Love's exact coefficients of uniform pressure on each rectangle,
            periodised exactly) or "spectral" (2 / (E* |k|) at the discrete wavenumbers; periodic
            only).
        method: "cg" (preconditioned constrained conjugate gradients, FFT-applied, any size) or
            "direct" (dense active-set solve, at most 8192 elements, the independent check).
        max_iterations: cap on solver iterations.
        raise_on_nonconvergence: raise :class:`ConvergenceError` when ``tol`` is not reached
            (default); with False the result is returned with ``converged=False``.

    Returns:
        A :class:`SurfaceResult` (pressure in Pa and envelope in m, both [iy, ix]).

    Raises:
        InvalidInputError: bad input, with the argument and the problem named.
        ConvergenceError: see ``raise_on_nonconvergence``.
    """
    values, dx_given, dy_given = spacing_of(heights, dx, "heights", dy, surface=True)
    z = as_float_array(values, "heights", 2)
    dx_f, dy_f = _spacings(dx_given, dy_given)
    e_f, p_f, nu_f = (to_float(youngs_modulus, "youngs_modulus"), to_float(mean_pressure, "mean_pressure"),
                      to_float(poisson, "poisson"))
    warn_if_implausible_texture(z, dx_f, "heights", row="surface row")
    warn_if_implausible_rubber(e_f, p_f)
    pressure, envelope, iterations, residual, converged = _core.solve_surface(
        z, dx_f, dy_f, e_f, nu_f, p_f, bool(periodic), kernel, method, to_float(tol, "tol"),
        positive_int(max_iterations, "max_iterations"),
    )
    if raise_on_nonconvergence and not converged:
        raise ConvergenceError(
            f"surface contact solver stopped after {iterations} iterations at residual {residual:.3g} > tol {tol:g}; "
            "raise max_iterations or tol, or pass raise_on_nonconvergence=False"
        )
    return SurfaceResult(z, dx_f, dy_f, pressure, envelope, iterations, residual, converged, e_f, nu_f, p_f)


def contact_surface_many(
    tiles: np.ndarray | Sequence[Sequence[Sequence[float]]],
    dx: float,
    dy: float | None = None,
    *,
    youngs_modulus: float | Sequence[float] | np.ndarray,
    mean_pressure: float,
    poisson: float = 0.5,
    tol: float = 1e-10,
    periodic: bool = True,
    kernel: Kernel = "element",
    method: Method = "cg",
    max_iterations: int = 2000,
    threads: int | None = None,
    warm_start: bool = False,
    raise_on_nonconvergence: bool = True,
    initial_pressure: np.ndarray | None = None,
) -> SurfaceBatch:
    """Solves :func:`contact_surface` for every tile of a stack and every modulus, in parallel.

    The kernel and FFT plans are built once; the (tile, modulus) problems run on a Rust thread
    pool with the GIL released. Results are bitwise identical whatever the thread count.

    Args:
        tiles: 3-D array of heights (m), ``[tile, iy, ix]``, every tile of the same shape.
        youngs_modulus: one E or a sequence of E values (Pa).
        threads: worker threads; None uses all cores (or RAYON_NUM_THREADS); at most 4 per
            usable core or 64, whichever is more (more only contend for the cores).
        warm_start: solve each tile's moduli in the order given, each CG solve starting from the
            previous modulus's solution: fewer iterations, results within ``tol`` of cold solves.
        initial_pressure: (tiles, moduli, ny, nx) pressures (Pa, >= 0), each problem's own start
            (e.g. an answer at a looser tol carried on to a tighter one); the problems then run in
            parallel, unchained (not with ``warm_start``). None: each cold problem from its nested
            start.
        Other arguments: as for :func:`contact_surface`.

    Returns:
        A :class:`SurfaceBatch` indexed ``[tile, modulus]``.
    """
    heights = as_float_array(tiles, "tiles", 3)
    moduli = moduli_array(youngs_modulus)
    threads = thread_count(threads)
    dx_f, dy_f = _spacings(dx, dy)
    p_f, nu_f = to_float(mean_pressure, "mean_pressure"), to_float(poisson, "poisson")
    if heights.size:
        warn_if_implausible_texture(heights.reshape(-1, heights.shape[-1]), dx_f, "tiles", row="surface row")
    warn_if_implausible_rubber(moduli, p_f)
    initial = None
    if initial_pressure is not None:
        if warm_start:
            raise InvalidInputError("initial_pressure gives every problem its own start: leave warm_start False")
        initial = np.ascontiguousarray(checked_initial_pressure(
            initial_pressure, (heights.shape[0], moduli.size, *heights.shape[1:]), "tiles, moduli, ny, nx"))
    pressure, envelope, iterations, residual, converged = _core.solve_surface_many(
        heights, dx_f, dy_f, np.ascontiguousarray(moduli), nu_f, p_f, bool(periodic), kernel, method,
        to_float(tol, "tol"), positive_int(max_iterations, "max_iterations"), threads, bool(warm_start), initial,
    )
    if raise_on_nonconvergence and not converged.all():
        bad = np.argwhere(~converged)
        raise ConvergenceError(
            f"{len(bad)} of {converged.size} problems did not reach tol {tol:g} "
            f"(first: tile {bad[0][0]}, modulus {moduli[bad[0][1]]:g} Pa, residual {residual[tuple(bad[0])]:.3g})"
        )
    return SurfaceBatch(heights, dx_f, dy_f, moduli, nu_f, p_f, pressure, envelope, iterations, residual, converged)
