"""Tyre/road contact on a line profile: the public solver API.

Units are SI: heights and dx in metres, moduli and pressures in pascals.
"""

from __future__ import annotations

from typing import Literal, Sequence

import numpy as np

from roadtex import _core
from roadtex._checks import (
    as_float_array,
    moduli_array,
    positive_int,
    required,
    spacing_of,
    thread_count,
    to_float,
    warn_if_implausible_rubber,
)
from roadtex.errors import ConvergenceError, InvalidInputError
from roadtex.models.results import ContactBatch, ContactResult
from roadtex.profiles.plausibility import warn_if_implausible_texture
from roadtex.profiles.profile import Profile

Kernel = Literal["element", "spectral"]
Method = Literal["cg", "direct"]


def contact(
    heights: Profile | np.ndarray | Sequence[float],
    dx: float | None = None,
    youngs_modulus: float | None = None,
    mean_pressure: float | None = None,
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
        heights: profile heights z (m), positive up, on N >= 8 equal elements; or a
            :class:`~roadtex.Profile` (equally spaced, no drop-outs), which carries its dx.
        dx: element width (m); the sample length is L = N dx. Required with an array; with a
            Profile it may be left out (given, it must be the Profile's).
        youngs_modulus: E of the rubber (Pa), e.g. 2.5e6 (required).
        mean_pressure: P, the mean contact pressure over L (Pa), e.g. 2e5 (required).
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
        ImplausibleParameterWarning: E outside 10 kPa to 10 GPa or P outside 100 Pa to 100 MPa:
            probably MPa given as Pa (silence it for dimensionless model problems).
    """
    values, dx_f, _ = spacing_of(heights, dx, "heights")
    z = as_float_array(values, "heights", 1)
    e_f, p_f, nu_f = (to_float(required(youngs_modulus, "youngs_modulus", "Pa"), "youngs_modulus"),
                      to_float(required(mean_pressure, "mean_pressure", "Pa"), "mean_pressure"), to_float(poisson, "poisson"))
    warn_if_implausible_texture(z, dx_f, "heights")
    warn_if_implausible_rubber(e_f, p_f)
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


def checked_initial_pressure(initial_pressure: np.ndarray, wanted: tuple[int, ...], axes: str) -> np.ndarray:
    """``initial_pressure`` as float64 (Pa), refused unless of shape ``wanted`` (``axes`` names
    them) and finite and >= 0: the one check of the problems' given starts, lines and surfaces."""
    initial = np.asarray(initial_pressure, dtype=np.float64)
    if initial.shape != wanted:
        raise InvalidInputError(f"initial_pressure must have shape ({axes}) = {wanted}, got {initial.shape}")
    if not np.all(np.isfinite(initial)) or (initial < 0).any():
        raise InvalidInputError("initial_pressure must be finite pressures >= 0 (Pa)")
    return initial


def _initial_rows(initial_pressure: np.ndarray, shape: tuple[int, ...], n_moduli: int) -> np.ndarray:
    """``initial_pressure`` (segments, moduli, N) checked against the problems and flattened to one
    row per problem, segment-major (as the core takes it)."""
    initial = checked_initial_pressure(initial_pressure, (shape[0], n_moduli, shape[1]), "segments, moduli, points")
    return np.ascontiguousarray(initial.reshape(shape[0] * n_moduli, shape[1]))


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
    coarse_start: int | None = None,
    initial_pressure: np.ndarray | None = None,
    raise_on_nonconvergence: bool = True,
) -> ContactBatch:
    """Solves :func:`contact` for every segment (row) and every modulus, in parallel.

    The kernel and FFT plans are built once; the (segment, modulus) problems run on a Rust thread
    pool with the GIL released. Each result is bitwise identical to a one-by-one :func:`contact`
    call, whatever the thread count.

    Args:
        segments: 2-D array of heights (m), one segment of N points per row.
        youngs_modulus: one E or a sequence of E values (Pa).
        threads: worker threads; None uses all cores (or RAYON_NUM_THREADS); at most 4 per
            usable core or 64, whichever is more (more only contend for the cores).
        warm_start: solve each segment's moduli in the order given, each CG solve starting from
            the previous modulus's solution (its contact set is close): fewer iterations. Results
            then meet ``tol`` as usual but are no longer bitwise those of one-by-one calls (they
            stay bitwise the same whatever the thread count). Ignored by ``method="direct"``.
        coarse_start: k when the segments are model grids ``k`` times finer than the data's (every
            ``k``-th point a reading, :func:`roadtex.models.grid.refine_periodic`): each segment's
            first modulus (every modulus without ``warm_start``) starts from the data grid's answer,
            the readings solved first (to ``tol`` or 1e-4, whichever is looser) and their pressure
            carried to the model grid linearly (mean pressure kept, p >= 0). Fewer iterations on
            the fine grid; results meet ``tol`` by the same test, within it of cold solves, and
            stay bitwise the same whatever the thread count. The segment length must be a multiple
            of ``k``; None or 1: no coarse start. Ignored by ``method="direct"``.
        initial_pressure: (segments, moduli, N) array of pressures (Pa, >= 0), each problem's start,
            typically a batch's ``pressure`` for the same readings joined by another road or solved
            to another tolerance on the same grid: each (segment, modulus) solve begins on that
            contact set (with ``warm_start`` or ``coarse_start`` it is refused). Results meet
            ``tol`` by the same test as cold solves, within it of them, and stay bitwise the same
            whatever the thread count. Ignored by ``method="direct"``.
        Other arguments: as for :func:`contact`.

    Returns:
        A :class:`ContactBatch` indexed ``[segment, modulus]``.
    """
    heights = as_float_array(segments, "segments", 2)
    moduli = moduli_array(youngs_modulus)
    threads = thread_count(threads)
    coarse = None if coarse_start is None else positive_int(coarse_start, "coarse_start")
    dx_f, p_f, nu_f = to_float(dx, "dx"), to_float(mean_pressure, "mean_pressure"), to_float(poisson, "poisson")
    warn_if_implausible_texture(heights, dx_f, "segments")
    warn_if_implausible_rubber(moduli, p_f)
    if initial_pressure is not None and (warm_start or coarse is not None):
        raise InvalidInputError("initial_pressure gives every problem its own start: leave warm_start and "
                                "coarse_start unset with it")
    initial = None if initial_pressure is None else _initial_rows(initial_pressure, heights.shape, moduli.size)
    pressure, envelope, iterations, residual, converged = _core.solve_many(
        heights, dx_f, np.ascontiguousarray(moduli), nu_f, p_f, bool(periodic), kernel, method,
        to_float(tol, "tol"), positive_int(max_iterations, "max_iterations"), threads, bool(warm_start),
        coarse, initial,
    )
    if raise_on_nonconvergence and not converged.all():
        bad = np.argwhere(~converged)
        raise ConvergenceError(
            f"{len(bad)} of {converged.size} problems did not reach tol {tol:g} "
            f"(first: segment {bad[0][0]}, modulus {moduli[bad[0][1]]:g} Pa, residual {residual[tuple(bad[0])]:.3g})"
        )
    return ContactBatch(heights, dx_f, moduli, nu_f, p_f, pressure, envelope, iterations, residual, converged)
