"""Areal contact (issue 16): closed forms, plane strain, the dense solve, invariances, hard cases,
determinism and input checks."""

from __future__ import annotations

import numpy as np
import pytest

import roadtex
from roadtex import reference as ref
from roadtex.errors import InvalidInputError

E = 2.5e6
E_STAR = E / 0.75
P = 2e5


def _rough_line(n: int, dx: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = np.arange(n) * dx
    length = n * dx
    return (1e-4 * np.sin(2 * np.pi * 3 * x / length) + 5e-5 * np.sin(2 * np.pi * 17 * x / length + 1.0)
            + 2e-5 * rng.standard_normal(n))


@pytest.mark.parametrize("kernel", ["element", "spectral"])
def test_extruded_line_profile_is_plane_strain(kernel: str) -> None:
    # A surface uniform across the road, periodic, is a plane-strain problem: every row must carry
    # the line model's pressure (the line solver, its Clausen kernel and its FFT path are independent
    # of the surface kernel and solver).
    dx = 2e-4
    line = _rough_line(256, dx, seed=1)
    expected = roadtex.contact(line, dx, E, P, kernel=kernel, tol=1e-12)
    assert 0.3 < expected.contact_fraction < 0.9
    surface = roadtex.contact_surface(np.tile(line, (8, 1)), dx, 1e-3, youngs_modulus=E, mean_pressure=P,
                                      kernel=kernel, tol=1e-12)
    assert np.max(np.abs(surface.pressure - expected.pressure[None, :])) < 1e-10 * P
    assert np.max(np.abs(surface.envelope - expected.envelope[None, :])) < 1e-10 * np.ptp(line)


def _bisinusoid(n: int, amplitude: float = 1e-4, length: float = 0.02) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    d = length / n
    x, y = np.meshgrid(np.arange(n) * d, np.arange(n) * d)
    z = amplitude * np.cos(2 * np.pi * x / length) * np.cos(2 * np.pi * y / (length / 2))
    return z, x, y, d


def test_bisinusoid_full_contact_spectral_kernel_is_exact() -> None:
    z, x, y, d = _bisinusoid(64)
    full = ref.bisinusoid_full_contact_pressure(1e-4, 0.02, 0.01, E_STAR)
    r = roadtex.contact_surface(z, d, youngs_modulus=E, mean_pressure=1.5 * full, kernel="spectral", tol=1e-12)
    exact = ref.bisinusoid_full_contact(x, y, 1e-4, 0.02, 0.01, E_STAR, 1.5 * full)
    assert r.in_contact.all()
    assert np.max(np.abs(r.pressure - exact)) < 1e-12 * full


def test_bisinusoid_full_contact_element_kernel_converges_at_second_order() -> None:
    errors = []
    for n in (32, 64, 128):
        z, x, y, d = _bisinusoid(n)
        full = ref.bisinusoid_full_contact_pressure(1e-4, 0.02, 0.01, E_STAR)
        r = roadtex.contact_surface(z, d, youngs_modulus=E, mean_pressure=1.5 * full, tol=1e-12)
        assert r.in_contact.all()
        errors.append(np.max(np.abs(r.pressure - ref.bisinusoid_full_contact(x, y, 1e-4, 0.02, 0.01, E_STAR, 1.5 * full))) / full)
    # Element averaging and aliasing: O((k d)^2), measured 6.8e-3, 1.9e-3, 4.8e-4.
    assert errors[-1] < 1e-3
    assert 3.5 < errors[0] / errors[1] < 4.2 and 3.5 < errors[1] / errors[2] < 4.2


def test_hertz_sphere_finite_model() -> None:
    n, side, radius = 128, 0.01, 0.05
    d = side / n
    xs = (np.arange(n) - n / 2 + 0.5) * d
    x, y = np.meshgrid(xs, xs)
    z = -(x**2 + y**2) / (2 * radius)
    mean_pressure = 1e4
    r = roadtex.contact_surface(z, d, youngs_modulus=E, mean_pressure=mean_pressure, periodic=False, tol=1e-10)
    force = mean_pressure * side * side
    exact, a = ref.hertz_sphere(np.hypot(x, y), radius, force, E_STAR)
    assert 20 < a / d < 40
    assert abs(r.pressure.max() / exact.max() - 1) < 1e-3
    assert np.sqrt(np.mean((r.pressure - exact) ** 2)) < 3e-3 * exact.max()
    contact_area = r.in_contact.sum() * d * d
    assert abs(contact_area / (np.pi * a * a) - 1) < 0.03
    assert r.pressure.sum() * d * d == pytest.approx(force, rel=1e-12)


@pytest.mark.parametrize("shape", [(16, 16), (12, 20)])
@pytest.mark.parametrize("periodic,kernel", [(True, "element"), (True, "spectral"), (False, "element")])
def test_cg_matches_the_dense_direct_solve(shape: tuple[int, int], periodic: bool, kernel: str) -> None:
    rng = np.random.default_rng(sum(shape))
    z = 1e-4 * rng.standard_normal(shape)
    kwargs = dict(youngs_modulus=5e6, mean_pressure=P, periodic=periodic, kernel=kernel, tol=1e-12)
    cg = roadtex.contact_surface(z, 1e-3, 2e-3, **kwargs)
    direct = roadtex.contact_surface(z, 1e-3, 2e-3, method="direct", **kwargs)
    assert 0.2 < cg.contact_fraction < 0.8
    assert np.array_equal(cg.in_contact, direct.in_contact)
    assert np.max(np.abs(cg.pressure - direct.pressure)) < 1e-9 * P


def test_translation_invariance() -> None:
    rng = np.random.default_rng(5)
    z = 1e-4 * rng.standard_normal((24, 40))
    r = roadtex.contact_surface(z, 1e-3, 1.5e-3, youngs_modulus=E, mean_pressure=P, tol=1e-12)
    shifted = roadtex.contact_surface(np.roll(z, (7, -11), axis=(0, 1)), 1e-3, 1.5e-3, youngs_modulus=E,
                                      mean_pressure=P, tol=1e-12)
    assert np.max(np.abs(np.roll(r.pressure, (7, -11), axis=(0, 1)) - shifted.pressure)) < 1e-9 * P


def test_needle_carries_the_peak_and_the_rest_stays_physical() -> None:
    z = np.zeros((32, 32))
    z[10, 20] = 1e-3
    r = roadtex.contact_surface(z, 1e-3, youngs_modulus=E, mean_pressure=P, tol=1e-10)
    assert r.converged and np.all(r.pressure >= 0) and np.all(r.envelope >= z - 1e-15)
    assert np.unravel_index(np.argmax(r.pressure), z.shape) == (10, 20)
    assert r.pressure.mean() == pytest.approx(P, rel=1e-12)


def test_very_stiff_rubber_puts_the_load_on_the_highest_element() -> None:
    rng = np.random.default_rng(2)
    z = 1e-4 * rng.standard_normal((16, 16))
    r = roadtex.contact_surface(z, 1e-3, youngs_modulus=1e13, mean_pressure=P, tol=1e-10)
    top = np.unravel_index(np.argmax(z), z.shape)
    assert r.in_contact.sum() == 1 and r.in_contact[top]
    assert r.pressure[top] == pytest.approx(z.size * P, rel=1e-12)


def test_flat_surface_carries_uniform_pressure() -> None:
    r = roadtex.contact_surface(np.full((8, 12), 0.1), 1e-3, 2e-3, youngs_modulus=E, mean_pressure=P)
    assert np.max(np.abs(r.pressure - P)) < 1e-9 * P


def test_batch_is_bitwise_identical_whatever_the_thread_count() -> None:
    rng = np.random.default_rng(9)
    tiles = 1e-4 * rng.standard_normal((3, 32, 24))
    moduli = [1e6, 5e6]
    one = roadtex.contact_surface_many(tiles, 1e-3, youngs_modulus=moduli, mean_pressure=P, threads=1)
    two = roadtex.contact_surface_many(tiles, 1e-3, youngs_modulus=moduli, mean_pressure=P, threads=2)
    assert np.array_equal(one.pressure, two.pressure) and np.array_equal(one.iterations, two.iterations)
    single = roadtex.contact_surface(tiles[2], 1e-3, youngs_modulus=5e6, mean_pressure=P)
    assert np.array_equal(single.pressure, one[2, 1].pressure)
    warm1 = roadtex.contact_surface_many(tiles, 1e-3, youngs_modulus=moduli, mean_pressure=P, threads=1, warm_start=True)
    warm2 = roadtex.contact_surface_many(tiles, 1e-3, youngs_modulus=moduli, mean_pressure=P, threads=2, warm_start=True)
    assert np.array_equal(warm1.pressure, warm2.pressure)
    assert np.max(np.abs(warm1.pressure - one.pressure)) < 1e-6 * P


def test_large_grid_parallel_transforms_are_bitwise_identical() -> None:
    # 192 x 192 >= 2^15 points: the row and column transforms run on rayon inside one solve.
    rng = np.random.default_rng(4)
    tiles = 1e-4 * rng.standard_normal((1, 192, 192))
    kwargs = dict(youngs_modulus=E, mean_pressure=P, tol=1e-8)
    one = roadtex.contact_surface_many(tiles, 1e-3, threads=1, **kwargs)
    two = roadtex.contact_surface_many(tiles, 1e-3, threads=2, **kwargs)
    assert one.converged.all() and np.array_equal(one.pressure, two.pressure)


@pytest.mark.parametrize("call,argument", [
    (lambda: roadtex.contact_surface(np.full((8, 8), np.nan), 1e-3, youngs_modulus=E, mean_pressure=P), "heights"),
    (lambda: roadtex.contact_surface(np.zeros(64), 1e-3, youngs_modulus=E, mean_pressure=P), "heights"),
    (lambda: roadtex.contact_surface(np.zeros((2, 64)), 1e-3, youngs_modulus=E, mean_pressure=P), "heights"),
    (lambda: roadtex.contact_surface(np.zeros((8, 8)), -1e-3, youngs_modulus=E, mean_pressure=P), "dx"),
    (lambda: roadtex.contact_surface(np.zeros((8, 8)), 1e-3, 0.0, youngs_modulus=E, mean_pressure=P), "dy"),
    (lambda: roadtex.contact_surface(np.zeros((8, 8)), 1e-3, youngs_modulus=-E, mean_pressure=P), "youngs_modulus"),
    (lambda: roadtex.contact_surface(np.zeros((8, 8)), 1e-3, youngs_modulus=E, mean_pressure=0.0), "mean_pressure"),
    (lambda: roadtex.contact_surface(np.zeros((8, 8)), 1e-3, youngs_modulus=E, mean_pressure=P, poisson=0.7), "poisson"),
    (lambda: roadtex.contact_surface(np.zeros((8, 8)), 1e-3, youngs_modulus=E, mean_pressure=P, kernel="x"), "kernel"),
    (lambda: roadtex.contact_surface(np.zeros((8, 8)), 1e-3, youngs_modulus=E, mean_pressure=P, method="x"), "method"),
    (lambda: roadtex.contact_surface(np.zeros((8, 8)), 1e-3, youngs_modulus=E, mean_pressure=P, periodic=False,
                                     kernel="spectral"), "spectral"),
    (lambda: roadtex.contact_surface(np.zeros((128, 128)), 1e-3, youngs_modulus=E, mean_pressure=P, method="direct"),
     "direct"),
    (lambda: roadtex.contact_surface(np.zeros((8, 8)), 1e-3, youngs_modulus=E, mean_pressure=P, tol=2.0), "tol"),
    (lambda: roadtex.contact_surface_many(np.zeros((8, 8)), 1e-3, youngs_modulus=E, mean_pressure=P), "tiles"),
    (lambda: roadtex.contact_surface_many(np.zeros((1, 8, 8)), 1e-3, youngs_modulus=[], mean_pressure=P),
     "youngs_modulus"),
    (lambda: roadtex.contact_surface_many(np.zeros((1, 8, 8)), 1e-3, youngs_modulus=E, mean_pressure=P, threads=0),
     "threads"),
])
def test_bad_input_names_the_argument(call, argument: str) -> None:
    with pytest.raises(InvalidInputError, match=argument):
        call()


def test_nonconvergence() -> None:
    rng = np.random.default_rng(1)
    z = 1e-4 * rng.standard_normal((32, 32))
    with pytest.raises(roadtex.ConvergenceError):
        roadtex.contact_surface(z, 1e-3, youngs_modulus=E, mean_pressure=P, max_iterations=2)
    r = roadtex.contact_surface(z, 1e-3, youngs_modulus=E, mean_pressure=P, max_iterations=2,
                                raise_on_nonconvergence=False)
    assert not r.converged and r.residual > 1e-10


def test_implausible_surface_warning_names_surface_rows() -> None:
    # heights in mm given as m: the warning says which surface row, not "segment"
    rng = np.random.default_rng(3)
    heights = rng.normal(0.0, 2.0, size=(4, 64))  # 2 m rms: millimetres taken for metres
    with pytest.warns(roadtex.errors.ImplausibleTextureWarning, match=r"surface row 0, 4 of 4 surface rows"):
        roadtex.contact_surface(heights, 1e-4, youngs_modulus=2.5e6, mean_pressure=2e5,
                                raise_on_nonconvergence=False)
