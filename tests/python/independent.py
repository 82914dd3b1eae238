"""The one independent check of a contact result, shared by the Python tests.

A returned :class:`roadtex.ContactResult` is checked here without the solver's own machinery: the
elastic surface u = C p / E* is recomputed with numpy from the real-space influence coefficients
(``roadtex._core.influence_coefficients``: the Clausen-function coefficients of the periodic
element kernel, or the finite Toeplitz coefficients), as the dense matrix product C p up to
``DENSE_LIMIT`` elements and as numpy's FFT convolution with the same coefficients beyond. The
solver's CG path never sees these coefficients: it applies the trigamma closed form of the
kernel's eigenvalues through the Rust FFT. The spectral kernel's eigenvalues 2 / |k| are written
here from their definition.

On that surface the contact conditions are checked directly: p >= 0, mean(p) = P, the envelope
>= the heights and == the heights where p > 0, and, when the result says it converged, u + h
(h one rigid approach) meets the profile on the contact set, does not penetrate it off the set,
and is the envelope there, all within the tolerance the result claims.

Used by test_properties.py, test_hard_cases.py and test_contact.py (``from independent import
check_contact``; ``tests/python`` is on ``sys.path``, see conftest.py).
"""

from __future__ import annotations

import math

import numpy as np

from roadtex import _core

#: Tolerance of the load balance mean(p) = P (it is exact by construction, up to rounding).
LOAD_BALANCE = 1e-11
#: The dense direct solve ignores ``tol``; when it reports convergence its residual is this small.
DIRECT_RESIDUAL = 1e-9
#: Up to this many elements the elastic surface is the dense matrix product C p; beyond, numpy's FFT
#: applies the same matrix (a dense N x N matrix of a million points would not fit).
DENSE_LIMIT = 2048


def kernel_multipliers(n: int, dx: float, kernel: str = "element") -> np.ndarray:
    """Eigenvalues lambda_q, q = 0 .. N/2, of the periodic kernel (m per unit p / E*).

    Element: the discrete Fourier transform of the real-space Clausen coefficients (the kernel
    is a real symmetric circulant, so its eigenvalues are the DFT of its first column). Spectral:
    2 / |k| = L / (pi q), and 0 for the mean (a uniform pressure moves the rubber rigidly)."""
    if kernel == "element":
        return np.fft.rfft(_core.influence_coefficients(n, dx, True)).real
    q = np.arange(n // 2 + 1, dtype=np.float64)
    multipliers = np.zeros_like(q)
    multipliers[1:] = n * dx / (math.pi * q[1:])
    return multipliers


def influence_matrix(n: int, dx: float, *, periodic: bool = True, kernel: str = "element") -> np.ndarray:
    """The dense N x N influence matrix C (m per unit p / E*): C[i, j] is the displacement at the
    centre of element i due to unit pressure on element j. Periodic: C[i, j] = c[(i - j) mod N]
    (circulant); finite: C[i, j] = c[|i - j|] (Toeplitz)."""
    i, j = np.ogrid[:n, :n]
    if not periodic:
        return _core.influence_coefficients(n, dx, False)[np.abs(i - j)]
    return influence_column(n, dx, kernel)[(i - j) % n]


def influence_column(n: int, dx: float, kernel: str = "element") -> np.ndarray:
    """The first column of the periodic kernel's circulant (m per unit p / E*)."""
    if kernel == "element":
        return _core.influence_coefficients(n, dx, True)
    return np.fft.irfft(kernel_multipliers(n, dx, kernel), n)


def elastic_displacement(pressure: np.ndarray, dx: float, e_star: float, *, periodic: bool = True,
                         kernel: str = "element") -> tuple[np.ndarray, float]:
    """u = C p / E* (m), and a bound on its rounding error (m).

    Up to ``DENSE_LIMIT`` elements, by the dense matrix product with :func:`influence_matrix`
    (no FFT at all). Beyond, the same matrix applied by numpy's FFT: periodic, the circulant of
    the real-space coefficients; finite, the Toeplitz matrix of the finite coefficients by a
    zero-padded circular convolution of size 2N.
    """
    n = pressure.size
    strain = pressure / e_star  # first, so that extreme E and P neither under- nor overflow
    column = influence_column(n, dx, kernel) if periodic else _core.influence_coefficients(n, dx, False)
    if n <= DENSE_LIMIT:
        u = influence_matrix(n, dx, periodic=periodic, kernel=kernel) @ strain
    elif periodic:
        u = np.fft.irfft(np.fft.rfft(strain) * np.fft.rfft(column).real, n)
    else:
        extended = np.concatenate([column, [0.0], column[:0:-1]])
        u = np.fft.irfft(np.fft.rfft(strain, 2 * n) * np.fft.rfft(extended), 2 * n)[:n]
    # Every u_i is a sum of N terms each at most max|C| p_j / E*: rounding is a small multiple of
    # eps log N (FFT) or eps N (dense, N <= DENSE_LIMIT) times that sum, for the solver as here.
    bound = 1e-12 * float(np.max(np.abs(column))) * float(np.sum(strain))
    return u, bound


def height_scale(heights: np.ndarray, mean_pressure: float, e_star: float, dx: float) -> float:
    """The residual's reference height: peak-to-valley, or P L / E* for a (nearly) flat profile."""
    z = heights - heights.max()
    load_scale = mean_pressure / e_star * dx * z.size
    span = float(z.max() - z.min())
    return span if span > 1e-9 * load_scale else load_scale


def check_contact(result, *, periodic: bool = True, kernel: str = "element", method: str = "cg",
                  tol: float = 1e-10, max_iterations: int | None = None, beyond_numpy: bool = False,
                  load_balance: float = LOAD_BALANCE, require_converged: bool = False) -> None:
    """The contract of a returned contact result, checked independently of the solver.

    Always: finite values, p >= 0, mean(p) = P (to ``load_balance``), envelope >= heights and
    == heights where p > 0, ``converged`` consistent with ``residual`` and ``tol`` (CG).
    ``require_converged``: the result must also say it converged, with a residual <= ``tol``.
    When converged: u + h (u recomputed by :func:`elastic_displacement`, h one rigid approach)
    meets the profile on the contact set and stays above it off it, within twice the tolerance
    plus rounding, and the envelope is that surface.

    ``beyond_numpy``: magnitudes so extreme that this numpy recomputation itself may overflow;
    the surface is then checked only where it could be computed.
    """
    z, p, s = result.heights, result.pressure, result.envelope
    n = z.size
    assert p.shape == (n,) and s.shape == (n,)
    assert np.all(np.isfinite(p)), "pressure has NaN or inf"
    assert np.all(np.isfinite(s)), "envelope has NaN or inf"
    assert math.isfinite(result.residual) and result.residual >= 0.0, f"residual {result.residual}"
    assert p.min() >= 0.0, f"negative pressure {p.min()}"
    balance = p.mean() / result.mean_pressure - 1.0
    assert abs(balance) <= load_balance, f"mean(p)/P - 1 = {balance:.3e}"
    assert np.all(s >= z), "envelope below the profile"
    assert np.array_equal(s[p > 0], z[p > 0]), "envelope leaves the profile where p > 0"
    if max_iterations is not None and method == "cg":  # the direct solve counts sweeps, uncapped
        assert result.iterations <= max_iterations
    if method == "cg":
        assert result.converged == (result.residual <= tol), (
            f"converged={result.converged} but residual {result.residual:.3e} vs tol {tol:g}")
    if require_converged:
        assert result.converged, f"not converged: residual {result.residual:.3e} after {result.iterations} iterations"
        assert result.residual <= tol, f"residual {result.residual:.3e} > tol {tol:g}"
    if not result.converged:
        return
    e_star = result.plane_strain_modulus
    top = z.max()
    zr = z - top
    with np.errstate(all="ignore" if beyond_numpy else "warn"):
        u, rounding = elastic_displacement(p, result.dx, e_star, periodic=periodic, kernel=kernel)
        scale = height_scale(z, result.mean_pressure, e_star, result.dx)
    if beyond_numpy and not (np.all(np.isfinite(u)) and np.isfinite(rounding) and np.isfinite(scale) and scale > 0):
        return
    if method == "direct":
        # The dense solve ignores tol: it stops when its active set settles, at a residual set by
        # rounding, which is large relative to the profile when C p / E* sums terms far larger
        # than the profile (P / E* >> its slopes).
        floor = rounding / scale
        assert result.residual <= max(tol, DIRECT_RESIDUAL, floor), f"direct residual {result.residual:.3e}"
    on = p > 0
    assert on.any(), "converged with no element in contact"
    lo, hi = float(np.min((zr - u)[on])), float(np.max((zr - u)[on]))
    approach = 0.5 * (lo + hi)
    surface = u + approach
    tol_checked = max(tol, result.residual)
    slack = 2.0 * tol_checked * scale + rounding + 8 * np.finfo(float).eps * (np.max(np.abs(zr)) + abs(top))
    assert 0.5 * (hi - lo) <= slack, (
        f"rubber surface leaves the profile on contact by {0.5 * (hi - lo):.3e} m > {slack:.3e} m "
        f"(tol {tol_checked:g}, scale {scale:.3e} m)")
    if not on.all():
        penetration = float(np.max((zr - surface)[~on]))
        assert penetration <= slack, f"rubber penetrates the profile by {penetration:.3e} m > {slack:.3e} m"
        expected = np.maximum(surface, zr)[~on] + top
        worst = float(np.max(np.abs(s[~on] - expected)))
        assert worst <= slack + 4 * np.finfo(float).eps * abs(top), f"envelope off the elastic surface by {worst:.3e} m"
