"""Accuracy and robustness of the periodic contact solver (roadtex.contact, roadtex.contact_many).

Every solve in this module goes through :func:`solve` (or :func:`solve_many`), which checks the
invariants of the discrete contact problem on the result before any test-specific assertion, with
the shared independent checker :func:`independent.check_contact`: load balance, p >= 0, envelope
>= heights, envelope == heights on contact, and that the envelope is the elastic surface produced
by the returned pressure (recomputed with numpy from the real-space influence coefficients).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import independent
import roadtex
from independent import check_contact
from roadtex import reference as ref
from roadtex.profiles.synthetic import self_affine_profile

# Road-like defaults: a 0.1 m sample, tread rubber, tyre inflation pressure.
ROAD_LENGTH = 0.1  # m
ROAD_SLOPE = 0.2  # rms slope of the synthetic profiles
TREAD_E = 2.5e6  # Pa
TYRE_P = 2e5  # Pa

# Westergaard wavy surface.
WAVE_LENGTH = 0.01  # m
WAVE_AMPLITUDE = 1e-4  # m


# --------------------------------------------------------------------------------------------
# helpers


def check(result: roadtex.ContactResult, kwargs: dict) -> None:
    """The shared independent check (:func:`independent.check_contact`) of a solve made with
    ``kwargs``: it must have converged to its tol, with mean(p) = P to 1e-12."""
    method = kwargs.get("method", "cg")
    check_contact(result, periodic=kwargs.get("periodic", True), kernel=kwargs.get("kernel", "element"),
                  method=method, tol=kwargs.get("tol", 1e-10), max_iterations=kwargs.get("max_iterations"),
                  load_balance=1e-12, require_converged=True)


def solve(heights, dx, youngs_modulus, mean_pressure, **kwargs) -> roadtex.ContactResult:
    """roadtex.contact followed by the independent check."""
    result = roadtex.contact(heights, dx, youngs_modulus, mean_pressure, **kwargs)
    check(result, kwargs)
    return result


def solve_many(segments, dx, moduli, mean_pressure, **kwargs) -> roadtex.ContactBatch:
    """roadtex.contact_many followed by the independent check of every problem."""
    batch = roadtex.contact_many(segments, dx, moduli, mean_pressure, **kwargs)
    for result in batch:
        check(result, kwargs)
    return batch


def rough(n: int, seed: int, length: float = ROAD_LENGTH) -> tuple[np.ndarray, float]:
    """A road-like self-affine profile (heights in m) and its dx."""
    return self_affine_profile(n, length, rms_slope=ROAD_SLOPE, seed=seed), length / n


def westergaard_errors(n: int, ratio: float, *, kernel: str = "element", poisson: float = 0.5,
                       tol: float = 1e-12) -> tuple[float, float, roadtex.ContactResult]:
    """L1 relative pressure error against the element-averaged exact solution, and the half-width
    error in elements, for the wavy surface at P = ratio p*."""
    e_star = TREAD_E / (1.0 - poisson**2)
    p_star = ref.westergaard_full_contact_pressure(WAVE_AMPLITUDE, WAVE_LENGTH, e_star)
    mean_pressure = ratio * p_star
    heights, dx = ref.westergaard_profile(n, WAVE_LENGTH, WAVE_AMPLITUDE)
    result = solve(heights, dx, TREAD_E, mean_pressure, poisson=poisson, kernel=kernel, tol=tol)
    exact = ref.westergaard_element_pressure(np.arange(n) * dx, dx, WAVE_AMPLITUDE, WAVE_LENGTH, e_star, mean_pressure)
    l1 = float(np.abs(result.pressure - exact).sum() / exact.sum())
    half_width = np.count_nonzero(result.pressure > 0.0) * dx / 2.0
    exact_half_width = ref.westergaard_contact_half_width(WAVE_AMPLITUDE, WAVE_LENGTH, e_star, mean_pressure)
    return l1, abs(half_width - exact_half_width) / dx, result


# --------------------------------------------------------------------------------------------
# the independent checker itself


@pytest.mark.parametrize("periodic, kernel", [(True, "element"), (True, "spectral"), (False, "element")])
def test_checker_dense_and_fft_products_agree(periodic, kernel):
    """The checker applies C densely up to DENSE_LIMIT and by numpy's FFT beyond: both are the
    same matrix, so on one pressure they agree (to the checker's own rounding bound)."""
    n, dx, e_star = 700, 1e-4, TREAD_E / 0.75
    pressure = TYRE_P * np.random.default_rng(1).exponential(size=n)
    dense, bound = independent.elastic_displacement(pressure, dx, e_star, periodic=periodic, kernel=kernel)
    column = (independent.influence_column(n, dx, kernel) if periodic
              else independent.influence_matrix(n, dx, periodic=False)[:, 0])
    strain = pressure / e_star
    if periodic:
        fft = np.fft.irfft(np.fft.rfft(strain) * np.fft.rfft(column).real, n)
    else:
        extended = np.concatenate([column, [0.0], column[:0:-1]])
        fft = np.fft.irfft(np.fft.rfft(strain, 2 * n) * np.fft.rfft(extended), 2 * n)[:n]
    assert 0 < np.max(np.abs(dense - fft)) <= bound or np.array_equal(dense, fft)
    assert np.ptp(dense) > 1e3 * bound  # the pressure does move the surface


def test_checker_rejects_wrong_answers():
    """The checker has teeth: a solved rough road passes, and each way of spoiling it fails: load
    off balance, pressure moved between contact elements (load kept), the envelope lifted off the
    elastic surface, or a gap left open on the contact set."""
    heights, dx = rough(512, seed=3)
    good = solve(heights, dx, TREAD_E, TYRE_P, tol=1e-12)
    on = np.flatnonzero(good.pressure > 0)
    off = np.flatnonzero(good.pressure == 0)
    assert on.size > 4 and off.size > 4
    unbalanced = good.pressure.copy()
    unbalanced[on[0]] *= 1.01
    moved = good.pressure.copy()
    shift = 0.05 * min(moved[on[0]], moved[on[-1]])
    moved[on[0]] -= shift
    moved[on[-1]] += shift
    lifted = good.envelope.copy()
    lifted[off[len(off) // 2]] += 1e-3 * np.ptp(heights)
    for spoiled, complaint in ((dataclasses.replace(good, pressure=unbalanced), "mean"),
                               (dataclasses.replace(good, pressure=moved), "leaves the profile on contact"),
                               (dataclasses.replace(good, envelope=lifted), "envelope off the elastic surface")):
        with pytest.raises(AssertionError, match=complaint):
            check_contact(spoiled, tol=1e-12, load_balance=1e-12, require_converged=True)
    # the same pressure on a profile with one contact element lowered: a gap opens on contact
    dented = heights.copy()
    dented[on[len(on) // 2]] -= 1e-3 * np.ptp(heights)
    envelope = np.where(good.pressure > 0, dented, good.envelope)
    with pytest.raises(AssertionError, match="leaves the profile on contact"):
        check_contact(dataclasses.replace(good, heights=dented, envelope=envelope), tol=1e-12, require_converged=True)


# --------------------------------------------------------------------------------------------
# Westergaard


@pytest.mark.parametrize("ratio", [0.05, 0.3, 0.9, 1.5])
def test_westergaard_pressure_and_contact_width(ratio):
    """Wavy surface at P/p* = ratio: L1 pressure error <= 5e-5 at N = 4096, falling from
    N = 1024 to 4096 to 16384, and the contact half-width within 2 dx of the exact one."""
    errors = {}
    for n in (1024, 4096, 16384):
        l1, width_error, _ = westergaard_errors(n, ratio)
        errors[n] = l1
        assert width_error <= 2.0, f"N={n}: half-width off by {width_error:.2f} dx"
    assert errors[4096] <= 5e-5, f"L1 error at N=4096: {errors[4096]:.3e}"
    assert errors[1024] > errors[4096] > errors[16384], f"errors do not fall with N: {errors}"


@pytest.mark.parametrize("poisson", [0.0, 0.3, -0.5])
def test_westergaard_uses_plane_strain_modulus(poisson):
    """The solution depends on E and nu only through E* = E / (1 - nu^2): Westergaard with
    p* built from E* is matched for compressible rubbers too."""
    l1, width_error, _ = westergaard_errors(4096, 0.3, poisson=poisson)
    assert l1 <= 5e-5
    assert width_error <= 2.0


def test_only_plane_strain_modulus_matters():
    """Two (E, nu) pairs with the same E* give the same pressure."""
    heights, dx = rough(512, seed=21)
    a = solve(heights, dx, TREAD_E, TYRE_P, poisson=0.5, tol=1e-12)
    b = solve(heights, dx, TREAD_E * (1.0 - 0.3**2) / (1.0 - 0.5**2), TYRE_P, poisson=0.3, tol=1e-12)
    assert np.max(np.abs(a.pressure - b.pressure)) / TYRE_P <= 1e-9


# --------------------------------------------------------------------------------------------
# flat profile


@pytest.mark.parametrize("level", [0.0, 0.05, -3e-3])
@pytest.mark.parametrize("n,kernel", [
    (8, "element"), (1000, "element"), (4096, "element"), (7919, "element"), (8, "spectral"), (4096, "spectral"),
])
def test_flat_profile_gives_uniform_pressure(n, kernel, level):
    """A flat road is in full contact under uniform pressure P (to 1e-12 relative)."""
    result = solve(np.full(n, level), 1e-4, TREAD_E, TYRE_P, kernel=kernel)
    worst = np.max(np.abs(result.pressure / TYRE_P - 1.0))
    assert worst <= 1e-12, f"max|p/P - 1| = {worst:.3e}"
    assert result.contact_fraction == 1.0


@pytest.mark.parametrize("n", [8, 1000])
def test_flat_profile_direct_solve(n):
    """The dense direct solve also gives uniform pressure P (to 1e-12 relative) on a flat road."""
    result = solve(np.full(n, 0.05), 1e-4, TREAD_E, TYRE_P, method="direct")
    worst = np.max(np.abs(result.pressure / TYRE_P - 1.0))
    assert worst <= 1e-12, f"max|p/P - 1| = {worst:.3e}"
    assert result.contact_fraction == 1.0


def test_direct_solve_reports_a_residual_beyond_tol_as_not_converged():
    """For method="direct", converged means the residual met tol, as for CG, not only that the
    active set settled: a tol below rounding is settled yet missed."""
    heights = self_affine_profile(256, 256 * 1e-4, rms_slope=ROAD_SLOPE, seed=4)
    settled = solve(heights, 1e-4, TREAD_E, TYRE_P, method="direct", tol=1e-12)
    assert settled.converged and settled.residual <= 1e-12
    missed = roadtex.contact(heights, 1e-4, TREAD_E, TYRE_P, method="direct", tol=1e-300, raise_on_nonconvergence=False)
    assert not missed.converged and missed.residual > 1e-300
    np.testing.assert_array_equal(missed.pressure, settled.pressure)
    with pytest.raises(RuntimeError, match="residual"):
        roadtex.contact(heights, 1e-4, TREAD_E, TYRE_P, method="direct", tol=1e-300)


# --------------------------------------------------------------------------------------------
# CG against the dense direct solve


@pytest.mark.parametrize("n", [256, 1024])
@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("youngs_modulus", [1e6, 2.5e6, 1e7])
def test_cg_agrees_with_direct_solve(n, seed, youngs_modulus):
    """CG (tol 1e-12) and the dense active-set solve agree to max|dp| / P <= 1e-8 on rough
    road-like profiles."""
    heights, dx = rough(n, seed)
    cg = solve(heights, dx, youngs_modulus, TYRE_P, tol=1e-12)
    direct = solve(heights, dx, youngs_modulus, TYRE_P, method="direct")
    assert 0.0 < cg.contact_fraction < 1.0  # a genuine partial-contact case
    diff = np.max(np.abs(cg.pressure - direct.pressure)) / TYRE_P
    assert diff <= 1e-8, f"max|p_cg - p_direct| / P = {diff:.3e}"


# --------------------------------------------------------------------------------------------
# symmetry and units


@pytest.mark.parametrize("shift", [1, 17, 511, 1021])
def test_circular_shift_shifts_solution(shift):
    """Rolling the periodic profile rolls the pressure (and envelope) by the same amount."""
    heights, dx = rough(1024, seed=4)
    base = solve(heights, dx, TREAD_E, TYRE_P, tol=1e-12)
    moved = solve(np.roll(heights, shift), dx, TREAD_E, TYRE_P, tol=1e-12)
    assert np.max(np.abs(moved.pressure - np.roll(base.pressure, shift))) / TYRE_P <= 1e-9
    assert np.max(np.abs(moved.envelope - np.roll(base.envelope, shift))) <= 1e-9 * np.ptp(heights)


def test_mirrored_profile_mirrors_solution():
    """Reversing the profile reverses the pressure (the kernel is symmetric)."""
    heights, dx = rough(1024, seed=9)
    base = solve(heights, dx, TREAD_E, TYRE_P, tol=1e-12)
    mirrored = solve(heights[::-1], dx, TREAD_E, TYRE_P, tol=1e-12)
    assert np.max(np.abs(mirrored.pressure - base.pressure[::-1])) / TYRE_P <= 1e-9


@pytest.mark.parametrize("peak_to_valley", [1e-5, 1e-1])
def test_units_do_not_cost_accuracy(peak_to_valley):
    """The same shape at micro- or macro-texture scale, with dx scaled alike (E, P unchanged), is
    the same dimensionless problem: same contact set and pressure to 1e-9 relative."""
    heights, dx = rough(1024, seed=3)
    base = solve(heights, dx, TREAD_E, TYRE_P, tol=1e-12)
    s = peak_to_valley / np.ptp(heights)
    scaled = solve(heights * s, dx * s, TREAD_E, TYRE_P, tol=1e-12)
    assert np.array_equal(scaled.in_contact, base.in_contact)
    assert np.max(np.abs(scaled.pressure - base.pressure)) / TYRE_P <= 1e-9
    assert np.max(np.abs(scaled.depth_below_envelope / s - base.depth_below_envelope)) <= 1e-9 * np.ptp(heights)


@pytest.mark.parametrize("peak_to_valley", [1e-5, 1e-1])
def test_height_scaling_with_load(peak_to_valley):
    """Heights scaled by s on the same grid with P scaled by s (E fixed) is the same problem
    with pressure scaled by s: same contact set, p / s equal to 1e-9 relative."""
    heights, dx = rough(1024, seed=3)
    base = solve(heights, dx, TREAD_E, TYRE_P, tol=1e-12)
    s = peak_to_valley / np.ptp(heights)
    scaled = solve(heights * s, dx, TREAD_E, TYRE_P * s, tol=1e-12)
    assert np.array_equal(scaled.in_contact, base.in_contact)
    assert np.max(np.abs(scaled.pressure / s - base.pressure)) / TYRE_P <= 1e-9


@pytest.mark.parametrize("offset", [0.1, -0.1])
def test_offset_profile_gives_same_pressure(offset):
    """Adding 0.1 m to every height (a profile measured from a far datum) changes nothing."""
    heights, dx = rough(1024, seed=3)
    base = solve(heights, dx, TREAD_E, TYRE_P, tol=1e-12)
    shifted = solve(heights + offset, dx, TREAD_E, TYRE_P, tol=1e-12)
    assert np.array_equal(shifted.in_contact, base.in_contact)
    assert np.max(np.abs(shifted.pressure - base.pressure)) / TYRE_P <= 1e-9
    assert np.max(np.abs(shifted.depth_below_envelope - base.depth_below_envelope)) <= 1e-9 * np.ptp(heights)


# --------------------------------------------------------------------------------------------
# hard cases


@pytest.mark.parametrize("method", ["cg", "direct"])
@pytest.mark.parametrize("youngs_modulus", [1e8, 1e9])
def test_single_spike_carries_all_load(method, youngs_modulus):
    """A flat profile with one element raised 1 mm under stiff rubber: that element alone is in
    contact and carries p = N P."""
    n, dx, spike = 256, 1e-4, 77
    heights = np.zeros(n)
    heights[spike] = 1e-3
    result = solve(heights, dx, youngs_modulus, TYRE_P, method=method, tol=1e-12)
    assert np.flatnonzero(result.pressure).tolist() == [spike]
    assert abs(result.pressure[spike] / (n * TYRE_P) - 1.0) <= 1e-12
    others = np.arange(n) != spike
    assert np.all(result.envelope[others] > heights[others])  # the rubber bridges the flat


def test_very_stiff_rubber_touches_a_handful_of_points():
    """Very stiff rubber on a rough profile touches only a few elements, the highest among them,
    and CG matches the direct solve."""
    heights, dx = rough(1024, seed=5)
    cg = solve(heights, dx, 1e9, TYRE_P, tol=1e-12)
    count = np.count_nonzero(cg.pressure)
    assert 1 <= count <= 10, f"{count} elements in contact"
    assert cg.in_contact[np.argmax(heights)]
    direct = solve(heights, dx, 1e9, TYRE_P, method="direct")
    assert np.max(np.abs(cg.pressure - direct.pressure)) / TYRE_P <= 1e-8


def test_very_soft_rubber_is_in_full_contact():
    """Very soft rubber (P / E* >> slopes) fills every valley, and CG matches the direct solve."""
    heights, dx = rough(1024, seed=5)
    cg = solve(heights, dx, 1e4, TYRE_P, tol=1e-12)
    assert cg.contact_fraction == 1.0
    assert np.array_equal(cg.envelope, heights)
    direct = solve(heights, dx, 1e4, TYRE_P, method="direct")
    assert np.max(np.abs(cg.pressure - direct.pressure)) / TYRE_P <= 1e-8


def test_prime_number_of_points():
    """N = 7919 (prime, worst case for the FFT): a rough profile converges, and Westergaard is
    as accurate as on power-of-two grids."""
    heights, dx = rough(7919, seed=7)
    result = solve(heights, dx, TREAD_E, TYRE_P, tol=1e-10, max_iterations=2000)
    assert 0.0 < result.contact_fraction < 1.0
    l1, width_error, _ = westergaard_errors(7919, 0.3, tol=1e-10)
    assert l1 <= 5e-5
    assert width_error <= 2.0


def test_million_point_profile():
    """N = 2**20: a 52 m self-affine profile sampled at 0.05 mm with texture down to 3.2 mm
    wavelength (64 dx) converges to tol 1e-8 with all invariants (thousands of contact islands;
    78 iterations when measured). Roughness down to 4 dx at this N (some 30,000 islands) takes
    about 180; see docs/performance.md."""
    n, dx = 2**20, 5e-5
    heights = self_affine_profile(n, n * dx, rms_slope=ROAD_SLOPE, cutoff_fraction=1 / 64, seed=11)
    result = solve(heights, dx, TREAD_E, TYRE_P, tol=1e-8, max_iterations=500)
    assert 0.0 < result.contact_fraction < 1.0


# --------------------------------------------------------------------------------------------
# spectral kernel


def test_spectral_kernel_full_contact_is_pointwise_exact():
    """With the continuous kernel 2 / (E* |k|), full contact on a sampled cosine gives
    p = P + p* cos(2 pi x / L) exactly at the nodes."""
    n = 1024
    e_star = TREAD_E / (1.0 - 0.5**2)
    p_star = ref.westergaard_full_contact_pressure(WAVE_AMPLITUDE, WAVE_LENGTH, e_star)
    heights, dx = ref.westergaard_profile(n, WAVE_LENGTH, WAVE_AMPLITUDE)
    result = solve(heights, dx, TREAD_E, 1.5 * p_star, kernel="spectral", tol=1e-12)
    exact = 1.5 * p_star + p_star * np.cos(2.0 * np.pi * np.arange(n) / n)
    assert np.max(np.abs(result.pressure - exact)) / p_star <= 1e-10


@pytest.mark.parametrize("ratio", [0.05, 0.3, 0.9, 1.5])
def test_spectral_kernel_converges_to_element_kernel(ratio):
    """kernel='spectral' solves Westergaard, and its difference from the element kernel falls as
    N grows (1024 -> 4096 -> 16384)."""
    differences = []
    for n in (1024, 4096, 16384):
        l1_spectral, width_error, spectral = westergaard_errors(n, ratio, kernel="spectral")
        _, _, element = westergaard_errors(n, ratio)
        assert width_error <= 2.0
        assert l1_spectral <= 2e-4
        differences.append(float(np.abs(spectral.pressure - element.pressure).sum() / (n * element.mean_pressure)))
    assert differences[0] > differences[1] > differences[2], differences
    assert differences[2] <= 1e-5


# --------------------------------------------------------------------------------------------
# contact_many


MANY_MODULI = [1e6, 2.5e6, 1e7]


@pytest.fixture(scope="module")
def segments() -> tuple[np.ndarray, float]:
    """Three rough segments of 512 points each."""
    rows = [rough(512, seed)[0] for seed in (31, 32, 33)]
    return np.stack(rows), ROAD_LENGTH / 512


def assert_same_result(a: roadtex.ContactResult, b: roadtex.ContactResult) -> None:
    """Bitwise equality of everything a solve returns."""
    assert np.array_equal(a.pressure, b.pressure)
    assert np.array_equal(a.envelope, b.envelope)
    assert a.iterations == b.iterations
    assert a.residual == b.residual
    assert a.converged == b.converged
    assert a.youngs_modulus == b.youngs_modulus


def test_contact_many_matches_one_by_one(segments):
    """contact_many[s, m] is bitwise identical to contact(segment s, modulus m)."""
    heights, dx = segments
    batch = solve_many(heights, dx, MANY_MODULI, TYRE_P, tol=1e-11, threads=2)
    assert batch.shape == (3, 3)
    assert len(batch) == 9
    assert batch.pressure.shape == (3, 3, 512)
    for s in range(3):
        for m, e in enumerate(MANY_MODULI):
            single = solve(heights[s], dx, e, TYRE_P, tol=1e-11)
            assert_same_result(batch[s, m], single)
            assert np.array_equal(batch[s, m].heights, heights[s])


def test_contact_many_independent_of_thread_count(segments):
    """threads=1, threads=2 and the default pool give bitwise identical batches."""
    heights, dx = segments
    one = solve_many(heights, dx, MANY_MODULI, TYRE_P, tol=1e-11, threads=1)
    two = solve_many(heights, dx, MANY_MODULI, TYRE_P, tol=1e-11, threads=2)
    default = solve_many(heights, dx, MANY_MODULI, TYRE_P, tol=1e-11)
    for other in (two, default):
        for field in ("pressure", "envelope", "iterations", "residual", "converged"):
            assert np.array_equal(getattr(one, field), getattr(other, field)), field


def test_contact_many_iterates_segment_major(segments):
    """Iterating a batch yields segment by segment, each for every modulus in order."""
    heights, dx = segments
    batch = solve_many(heights, dx, MANY_MODULI, TYRE_P)
    results = list(batch)
    assert len(results) == 9
    for k, result in enumerate(results):
        s, m = divmod(k, 3)
        assert result.youngs_modulus == MANY_MODULI[m]
        assert np.array_equal(result.heights, heights[s])
        assert np.array_equal(result.pressure, batch.pressure[s, m])


def test_contact_many_scalar_modulus(segments):
    """A single E gives a (segments, 1) batch equal to one-by-one calls."""
    heights, dx = segments
    batch = solve_many(heights, dx, TREAD_E, TYRE_P, threads=2)
    assert batch.shape == (3, 1)
    for s in range(3):
        assert_same_result(batch[s, 0], solve(heights[s], dx, TREAD_E, TYRE_P))


def test_contact_many_stiffer_rubber_touches_less(segments):
    """On each segment the contact fraction falls as E rises (physics check across the batch)."""
    heights, dx = segments
    batch = solve_many(heights, dx, MANY_MODULI, TYRE_P, threads=2)
    for s in range(3):
        fractions = [batch[s, m].contact_fraction for m in range(3)]
        assert fractions[0] > fractions[1] > fractions[2], fractions


def test_warm_start_across_moduli_meets_tol_and_agrees_with_cold_solves() -> None:
    """contact_many(warm_start=True) starts each modulus from the previous one's solution: every
    result must still meet tol on its own terms, agree with the cold solve to the accuracy tol
    allows, and stay bitwise the same whatever the thread count."""
    rng = np.random.default_rng(11)
    n, dx = 1000, 5e-4
    segments = np.stack([self_affine_profile(n, n * dx, hurst=0.8, rms_slope=0.2, seed=int(s))
                         for s in rng.integers(0, 10_000, 6)])
    moduli = [1e6, 2e6, 5e6, 1e7]
    cold = roadtex.contact_many(segments, dx, moduli, TYRE_P, tol=1e-9, threads=1)
    warm = roadtex.contact_many(segments, dx, moduli, TYRE_P, tol=1e-9, threads=1, warm_start=True)
    warm2 = roadtex.contact_many(segments, dx, moduli, TYRE_P, tol=1e-9, threads=2, warm_start=True)
    assert warm.converged.all() and (warm.residual <= 1e-9).all()
    assert np.array_equal(warm.pressure, warm2.pressure) and np.array_equal(warm.iterations, warm2.iterations)
    assert np.allclose(warm.pressure.mean(axis=2), TYRE_P, rtol=1e-12)
    ptv = np.ptp(segments, axis=1)[:, None, None]
    assert np.max(np.abs(warm.envelope - cold.envelope) / ptv) < 1e-7
    assert np.array_equal(warm.pressure[:, 0], cold.pressure[:, 0])  # the first modulus starts cold
    assert warm.iterations[:, 1:].sum() < cold.iterations[:, 1:].sum()
