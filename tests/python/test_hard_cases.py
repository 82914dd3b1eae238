"""Numerical hard cases of the contact model, each with its expected behaviour stated and tested.

Every converged result here also passes :func:`independent.check_contact`, the shared independent
check of the contact conditions (elastic surface recomputed with numpy from the influence
coefficients).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import roadtex
from independent import check_contact, kernel_multipliers
from roadtex.errors import ImplausibleTextureWarning, RoadtexWarning
from roadtex.profiles.pavements import synthetic_pavement
from roadtex.profiles.plausibility import PLAUSIBLE_MEDIAN_SLOPE, PLAUSIBLE_PEAK_TO_VALLEY, PLAUSIBLE_RMS
from roadtex.profiles.synthetic import self_affine_profile

E = 2.5e6  # Pa, tread rubber
P = 2e5  # Pa, tyre inflation pressure


def solve(heights, dx, youngs_modulus=E, mean_pressure=P, **kwargs) -> roadtex.ContactResult:
    """roadtex.contact followed by the independent check."""
    result = roadtex.contact(heights, dx, youngs_modulus, mean_pressure, **kwargs)
    check_contact(result, periodic=kwargs.get("periodic", True), kernel=kwargs.get("kernel", "element"),
                  method=kwargs.get("method", "cg"), tol=kwargs.get("tol", 1e-10))
    return result


def islands(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index of each run of True."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return [(int(a), int(b) - 1) for a, b in edges.reshape(-1, 2)]


# --------------------------------------------------------------------------------------------
# one needle spike


@pytest.fixture(scope="module")
def rough_road() -> tuple[np.ndarray, float, roadtex.ContactResult]:
    """A road-like profile (0.2 m, 4096 points, texture down to 0.8 mm) and its solution."""
    n, length = 4096, 0.2
    z = self_affine_profile(n, length, rms_slope=0.2, cutoff_fraction=1 / 16, seed=5)
    return z, length / n, solve(z, length / n)


def test_needle_spike_takes_load_and_lifts_the_rubber_around_it(rough_road):
    """One element raised above the whole texture (a stone edge, or a spike the conditioning
    missed), by 0.5, 1, 3 and 10 times the texture's peak-to-valley.

    Expected: the needle is in contact and carries the highest pressure; the rubber is held off
    around it, so no element comes into contact that was not in contact without the needle;
    the higher the needle, the larger its share of the load and the smaller the contact
    fraction. All solves converge and pass the independent check."""
    z, dx, base = rough_road
    k = 1000
    shares, fractions = [], []
    for multiple in (0.5, 1.0, 3.0, 10.0):
        needled = z.copy()
        needled[k] = z.max() + multiple * np.ptp(z)
        r = solve(needled, dx)
        assert r.pressure[k] > 0 and np.argmax(r.pressure) == k
        others = np.arange(z.size) != k
        assert not np.any((r.pressure > 0) & (base.pressure == 0) & others), "contact appeared beside the needle"
        shares.append(r.pressure[k] / (z.size * P))
        fractions.append(r.contact_fraction)
    assert all(a < b for a, b in zip(shares, shares[1:])), shares
    assert all(a > b for a, b in zip(fractions, fractions[1:])), fractions
    assert fractions[0] < base.contact_fraction and shares[-1] > 0.5


def test_needle_spike_cg_agrees_with_the_dense_solve():
    """The needle case at N = 1024: CG (tol 1e-12) and the dense direct solve agree to 1e-8 P."""
    n, length = 1024, 0.05
    z = self_affine_profile(n, length, rms_slope=0.2, seed=6)
    z[300] = z.max() + 3 * np.ptp(z)
    cg = solve(z, length / n, tol=1e-12)
    direct = solve(z, length / n, method="direct")
    assert np.max(np.abs(cg.pressure - direct.pressure)) / P <= 1e-8


# --------------------------------------------------------------------------------------------
# porous asphalt: pores 50 times deeper than wide


@pytest.mark.parametrize("youngs_modulus", [1e6, 2.5e6, 1e7])
def test_narrow_deep_pores_are_bridged(youngs_modulus):
    """Flat stone tops with pores 2 elements (0.1 mm) wide and 5 mm deep (50 times deeper than
    wide), every 8.65 mm.

    Expected: the rubber bridges every pore: the contact set is exactly the land between pores
    (a flat face pressed on rubber stays in contact up to its edges), no pore element is
    touched, and the rubber sags into a pore by about P w / E* (the opening of a pressurised
    crack of width w: 2 P (w/2) / E*), within 10 %, far from the 5 mm bottom. The pressure peaks
    at the pore edges, above P."""
    n, dx, width = 2048, 5e-5, 2
    depth = 50 * width * dx
    z = np.zeros(n)
    starts = np.arange(37, n - width, 173)
    for s in starts:
        z[s:s + width] = -depth
    r = solve(z, dx, youngs_modulus)
    land = z == 0
    assert np.array_equal(r.pressure > 0, land)
    sag = -float(np.min(r.envelope[~land]))
    e_star = youngs_modulus / (1 - 0.5**2)
    expected = P * width * dx / e_star
    assert sag == pytest.approx(expected, rel=0.1), f"sag {sag:.3e} m, P w / E* = {expected:.3e} m"
    assert sag < 0.01 * depth
    edges = np.concatenate([starts - 1, starts + width])
    assert np.all(r.pressure[edges] > 1.2 * P)
    assert np.all(r.pressure[edges] >= np.max(r.pressure[land & ~np.isin(np.arange(n), edges)]))


def test_synthetic_porous_asphalt_converges_and_agrees_with_the_dense_solve():
    """The synthetic porous asphalt (deep narrow pores between chippings) at 0.05 mm sampling:
    CG converges, passes the check, and agrees with the dense solve to 1e-8 P."""
    profile = synthetic_pavement("porous_asphalt", 0.1, 5e-5, seed=2)
    z = profile.heights[:2048]
    cg = solve(z, profile.dx, tol=1e-12)
    direct = solve(z, profile.dx, method="direct")
    assert 0 < cg.contact_fraction < 1
    assert np.max(np.abs(cg.pressure - direct.pressure)) / P <= 1e-8


# --------------------------------------------------------------------------------------------
# perfectly flat


@pytest.mark.parametrize("level", [0.0, 350.0])
@pytest.mark.parametrize("n, method, kernel", [(8, "cg", "element"), (1000, "cg", "element"), (7919, "cg", "element"),
                                               (8, "cg", "spectral"), (7919, "cg", "spectral"),
                                               (8, "direct", "element"), (1000, "direct", "element")])
def test_flat_profile_has_uniform_pressure(n, level, method, kernel):
    """A perfectly flat profile, at 0 m or at 350 m (heights above a datum): full contact,
    envelope == heights, pressure P everywhere to 1e-12, converged in at most a couple of steps
    (the residual's scale is then P L / E*, since the profile has no height)."""
    r = solve(np.full(n, level), 1e-4, method=method, kernel=kernel)
    assert r.contact_fraction == 1.0 and np.array_equal(r.envelope, r.heights)
    assert np.max(np.abs(r.pressure / P - 1)) <= 1e-12
    assert r.iterations <= 2


def test_flat_profile_finite_model_has_edge_over_pressures():
    """The finite model on a flat sample is a flat punch: full contact, pressure symmetric,
    lowest in the middle and highest at both ends (edge over-pressures), mean P."""
    n = 1000
    r = solve(np.zeros(n), 1e-4, periodic=False)
    p = r.pressure
    assert r.contact_fraction == 1.0
    assert np.allclose(p, p[::-1], rtol=1e-9)
    assert p[0] == p.max() and p[0] > 3 * P and abs(p[n // 2] / (P * 2 / np.pi) - 1) < 0.01


# --------------------------------------------------------------------------------------------
# staircase


def test_staircase_touches_every_tread_at_its_nose():
    """A periodic staircase: 16 treads of 64 elements rising by 0.5 mm each, then a cliff back
    down (the periodic repeat).

    Expected: every contact island starts at a tread's nose (the top of a riser) and stays on
    that tread; the highest tread is in contact over its whole length; higher treads carry
    longer islands; the highest pressure is at a convex corner (a nose, or the cliff edge); CG
    agrees with the dense solve to 1e-8 P."""
    n, dx, tread, rise = 1024, 5e-5, 64, 0.5e-3
    z = np.floor(np.arange(n) / tread) * rise
    r = solve(z, dx, tol=1e-12)
    found = islands(r.pressure > 0)
    assert len(found) >= 3
    lengths = []
    for first, last in found:
        assert first % tread == 0, f"island {first}..{last} does not start at a nose"
        assert first // tread == last // tread, f"island {first}..{last} spans a riser"
        lengths.append(last - first + 1)
    assert found[-1] == (n - tread, n - 1), "the top tread is not fully in contact"
    assert all(a < b for a, b in zip(lengths, lengths[1:])), lengths
    corners = {k * tread for k in range(n // tread)} | {n - 1}
    assert int(np.argmax(r.pressure)) in corners
    direct = solve(z, dx, method="direct")
    assert np.max(np.abs(r.pressure - direct.pressure)) / P <= 1e-8


# --------------------------------------------------------------------------------------------
# rigid rubber, full contact


@pytest.mark.parametrize("method", ["cg", "direct"])
def test_rubber_so_stiff_that_one_element_carries_the_load(method):
    """E = 1e13 Pa (stiffer than diamond) on a rough road profile: the rubber is effectively
    rigid and rests on the single highest element, which carries the whole load, p = N P
    (to 1e-12); the envelope elsewhere is that rigid line (checked independently)."""
    n, length = 1024, 0.05
    z = self_affine_profile(n, length, rms_slope=0.2, seed=8)
    r = solve(z, length / n, 1e13, method=method, tol=1e-12)
    assert np.flatnonzero(r.pressure).tolist() == [int(np.argmax(z))]
    assert r.pressure.max() / (n * P) == pytest.approx(1.0, abs=1e-12)
    assert np.max(r.envelope - z.max()) <= 1e-9 * np.ptp(z)


def full_contact_pressure(z: np.ndarray, dx: float, e_star: float, mean_pressure: float) -> np.ndarray:
    """p = P + E* C^-1 (z - mean z): the pressure that makes the rubber follow the profile
    everywhere (periodic element kernel), computed with numpy from the real-space influence
    coefficients. For a cosine it is Westergaard's full-contact solution P + p* cos(2 pi x / L)."""
    multipliers = kernel_multipliers(z.size, dx, "element")
    spectrum = np.fft.rfft(z - z.mean())
    spectrum[1:] /= multipliers[1:]
    spectrum[0] = 0.0
    return mean_pressure + e_star * np.fft.irfft(spectrum, z.size)


def test_pressure_so_high_that_contact_is_full():
    """P five times the pressure needed to close every valley on a rough profile: contact
    everywhere, p > 0 everywhere, envelope == heights, and p equal to the full-contact solution
    P + E* C^-1 (z - mean z) (to 1e-9 of its variation)."""
    n, length = 2048, 0.1
    z = self_affine_profile(n, length, rms_slope=0.2, seed=9)
    e_star = E / (1 - 0.5**2)
    needed = -float(np.min(full_contact_pressure(z, length / n, e_star, 0.0)))
    mean_pressure = 5 * needed
    r = solve(z, length / n, mean_pressure=mean_pressure, tol=1e-12)
    assert r.contact_fraction == 1.0 and np.all(r.pressure > 0)
    assert np.array_equal(r.envelope, z)
    expected = full_contact_pressure(z, length / n, e_star, mean_pressure)
    assert np.max(np.abs(r.pressure - expected)) <= 1e-9 * np.ptp(expected)


def test_pressure_just_below_full_contact_leaves_the_deepest_valley_open():
    """Just below the pressure that closes every valley (0.9 of it), the element where the
    full-contact solution is most negative is the one left out of contact."""
    n, length = 2048, 0.1
    z = self_affine_profile(n, length, rms_slope=0.2, seed=9)
    e_star = E / (1 - 0.5**2)
    shape = full_contact_pressure(z, length / n, e_star, 0.0)
    r = solve(z, length / n, mean_pressure=-0.9 * float(shape.min()), tol=1e-12)
    assert 0.9 < r.contact_fraction < 1.0
    assert r.pressure[int(np.argmin(shape))] == 0.0


# --------------------------------------------------------------------------------------------
# heights in millimetres by mistake


def road_profiles() -> dict[str, tuple[np.ndarray, float]]:
    """One 0.2 m run of every synthetic pavement kind at 0.05 mm, plus the 2^20-point 52 m
    synthetic profile of test_contact (heights in metres)."""
    out = {}
    for kind in ("dense_asphalt", "porous_asphalt", "cement_concrete", "surface_dressing"):
        p = synthetic_pavement(kind, 0.2, 5e-5, seed=1)
        out[kind] = (np.asarray(p.heights), p.dx)
    n, dx = 2**20, 5e-5
    out["self-affine 52 m"] = (self_affine_profile(n, n * dx, rms_slope=0.2, cutoff_fraction=1 / 64, seed=11), dx)
    return out


@pytest.fixture(scope="module")
def roads() -> dict[str, tuple[np.ndarray, float]]:
    return road_profiles()


def test_heights_in_metres_give_no_warning(roads):
    """Every road-like profile in metres passes without ImplausibleTextureWarning, alone or in
    a batch (the solve is cut short: only the check before it matters here)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RoadtexWarning)
        for _name, (z, dx) in roads.items():
            roadtex.contact(z[:8192], dx, E, P, max_iterations=1, raise_on_nonconvergence=False)
        z, dx = roads["dense_asphalt"]
        roadtex.contact_many(z[:4000].reshape(4, 1000), dx, [E, 2 * E], P, max_iterations=1,
                             raise_on_nonconvergence=False)
        big, dx = roads["self-affine 52 m"]
        from roadtex.profiles.plausibility import warn_if_implausible_texture
        warn_if_implausible_texture(big, dx, "heights")  # the whole 2^20 profile, without a 2^20 solve


def test_heights_in_millimetres_warn_and_still_solve(roads):
    """The same profiles with heights 1000 times too large (millimetres given as metres) warn
    with ImplausibleTextureWarning (a RoadtexWarning, a UserWarning) whose message says what is
    wrong and suggests millimetres; the problem is still solved as given."""
    assert issubclass(ImplausibleTextureWarning, RoadtexWarning) and issubclass(RoadtexWarning, UserWarning)
    for _name, (z, dx) in roads.items():
        with pytest.warns(ImplausibleTextureWarning, match=r"implausible for a road.*millimetres"):
            r = roadtex.contact(z[:4096] * 1000, dx, E, P, tol=1e-8, raise_on_nonconvergence=False)
        assert r.pressure.mean() == pytest.approx(P, rel=1e-12)


def test_millimetres_in_one_segment_of_a_batch_are_named():
    """contact_many warns once and names the first implausible segment and how many there are."""
    p = synthetic_pavement("dense_asphalt", 0.2, 5e-5, seed=3)
    segments = np.asarray(p.heights)[:4000].reshape(4, 1000).copy()
    segments[2] *= 1000
    with pytest.warns(ImplausibleTextureWarning, match=r"segments \(segment 2, 1 of 4 segments\)") as caught:
        roadtex.contact_many(segments, p.dx, E, P, tol=1e-8, raise_on_nonconvergence=False)
    assert len([w for w in caught if issubclass(w.category, ImplausibleTextureWarning)]) == 1


@pytest.mark.parametrize("case", ["sentinel", "peak-to-valley", "rms", "slope"])
def test_each_plausibility_limit_triggers_alone(case):
    """Each documented limit warns by itself: a single 2 m spike (peak-to-valley > 1 m), a
    +-0.3 m square wave (rms > 0.25 m), a 0.1 mm texture given in mm on a 0.05 mm grid (median
    slope > 20); and a drop-out written as -9999 (a common sentinel) trips the first two."""
    n, dx = 4096, 5e-5
    x = np.arange(n)
    texture = 1e-4 * np.sin(x / 7)
    z = {
        "sentinel": np.where(x == 100, -9999.0, texture),
        "peak-to-valley": np.where(x == 100, 2.0, texture),
        "rms": 0.3 * np.sign(np.sin(4 * np.pi * (x + 0.5) / n)) + texture,
        "slope": 1000 * texture,
    }[case]
    detrended = z - np.polyval(np.polyfit(x, z, 1), x)
    over = {"peak-to-valley": np.ptp(detrended) > PLAUSIBLE_PEAK_TO_VALLEY, "rms": detrended.std() > PLAUSIBLE_RMS,
            "slope": np.median(np.abs(np.diff(z))) / dx > PLAUSIBLE_MEDIAN_SLOPE}
    assert [k for k, v in over.items() if v] == (["peak-to-valley", "rms"] if case == "sentinel" else [case])
    with pytest.warns(ImplausibleTextureWarning):
        roadtex.contact(z, dx, E, P, max_iterations=1, raise_on_nonconvergence=False)


def test_nan_heights_give_the_value_error_not_a_warning():
    """Heights with NaN: the ValueError of the input checks, and no plausibility warning."""
    z = 1e-4 * np.sin(np.arange(64.0))
    z[5] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error", RoadtexWarning)
        with pytest.raises(ValueError, match="non-finite"):
            roadtex.contact(z, 1e-4, E, P)


# --------------------------------------------------------------------------------------------
# one large messy profile


def test_large_messy_survey_profile():
    """N = 2^17 (6.5 m at 0.05 mm): a dense asphalt with what old survey files hold: needle
    spikes, drop-outs filled flat (plateaus), a step (a joint) and heights quantised to 10 um.
    CG converges to tol 1e-8 within the iteration cap and passes the independent check."""
    n, dx = 2**17, 5e-5
    z = np.asarray(synthetic_pavement("dense_asphalt", n * dx, dx, seed=4).heights)[:n].copy()
    rng = np.random.default_rng(4)
    z[rng.integers(0, n, 20)] += 3 * np.ptp(z)
    for start in rng.integers(0, n - 500, 10):
        z[start:start + rng.integers(5, 500)] = z[start]
    z[n // 3:] += 2e-3
    z = np.round(z / 1e-5) * 1e-5
    r = solve(z, dx, tol=1e-8, max_iterations=2000)
    assert 0 < r.contact_fraction < 1
