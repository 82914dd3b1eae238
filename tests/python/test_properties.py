"""Property-based tests (hypothesis) of the public API on messy, random input.

The promise under test, for every call: it raises a clear ``ValueError``, or it returns a result
that is right, or it says honestly that it is not (``converged=False``). Nothing else: no crash,
no hang, no NaN, no wrong answer flagged converged.

A returned contact result is checked independently of the solver by the shared checker
:func:`independent.check_contact` (tests/python/independent.py): the elastic surface is recomputed
with numpy from the real-space influence coefficients (``roadtex._core.influence_coefficients``),
as a dense matrix product or numpy's FFT, never the Rust FFT path, and the contact conditions are
checked on it directly.

Budget: a few hundred examples in all, about a minute on 2 cores. The examples are derandomized
(same inputs every run, so CI is reproducible). ``ROADTEX_HYPOTHESIS=thorough`` runs 20 times
more, with fresh random inputs, for a local hunt:

    ROADTEX_HYPOTHESIS=thorough .venv/bin/python -m pytest -q tests/python/test_properties.py
"""

from __future__ import annotations

import os
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import roadtex
from independent import LOAD_BALANCE, check_contact
from roadtex import _core
from roadtex.models.clapp import clapp
from roadtex.profiles import Profile, read_profile, write_profile
from roadtex.spectra import band_levels

_THOROUGH = os.environ.get("ROADTEX_HYPOTHESIS") == "thorough"
settings.register_profile("roadtex-ci", derandomize=True, deadline=None, print_blob=True, database=None,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                                 HealthCheck.function_scoped_fixture])
settings.register_profile("roadtex-thorough", parent=settings.get_profile("roadtex-ci"), derandomize=False)
_PROFILE = settings.get_profile("roadtex-thorough" if _THOROUGH else "roadtex-ci")


def budget(examples: int) -> settings:
    """The CI settings with ``examples`` examples (20 times more when thorough)."""
    return settings(_PROFILE, max_examples=examples * (20 if _THOROUGH else 1))


# The strategies draw heights, E and P over many decades on purpose: the unit warnings are expected.
pytestmark = [pytest.mark.filterwarnings("ignore::roadtex.errors.ImplausibleTextureWarning"),
              pytest.mark.filterwarnings("ignore::roadtex.errors.ImplausibleParameterWarning")]

# --------------------------------------------------------------------------------------------
# strategies


@st.composite
def shapes(draw, min_n: int = 8, max_n: int = 1024) -> np.ndarray:
    """A profile shape of unit peak-to-valley (or flat): a base (flat, rough, sine, noise,
    staircase) with spikes, plateaus, steps, pores and repeated (quantised) values."""
    n = draw(st.one_of(st.integers(min_n, min(64, max_n)), st.integers(min_n, max_n)))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    base = draw(st.sampled_from(["flat", "rough", "sine", "noise", "staircase"]))
    x = np.arange(n)
    if base == "flat":
        z = np.zeros(n)
    elif base == "rough":
        z = _core.self_affine_profile(n, 1.0, 0.8, 0.2, min(0.5, 8.0 / n * 4), seed)
    elif base == "sine":
        z = np.sin(2 * np.pi * draw(st.integers(1, max(1, n // 4))) * x / n + rng.uniform(0, 2 * np.pi))
    elif base == "noise":
        z = rng.standard_normal(n)
    else:
        z = np.floor(x / draw(st.integers(1, max(1, n // 2))))
    span = float(np.ptp(z)) or 1.0
    z = z / span
    for _ in range(draw(st.integers(0, 3))):  # needle spikes, up or down
        z[rng.integers(n)] += draw(st.sampled_from([-20.0, -1.0, 1.0, 5.0, 50.0]))
    if draw(st.booleans()):  # a plateau
        start = int(rng.integers(n))
        z[start:start + int(rng.integers(1, n + 1))] = z[start]
    if draw(st.booleans()):  # a step
        z[int(rng.integers(n)):] += draw(st.sampled_from([-1.0, 0.5, 3.0]))
    if draw(st.booleans()):  # repeated values: a coarse height quantisation, as in old surveys
        z = np.round(z * draw(st.sampled_from([1, 4, 50]))) / 50.0
    span = float(np.ptp(z))
    return z / span if span > 0 else z


@st.composite
def contact_problems(draw, max_n: int = 1024) -> dict:
    """A contact problem: a shape at a scale from 1 nm to 10 m, with an offset; E and P over six
    decades each, dx over five; both models, both kernels, both methods; tight and loose tol;
    max_iterations from 3 (often too few) to the default."""
    shape = draw(shapes(max_n=max_n))
    n = shape.size
    scale = 10.0 ** draw(st.floats(-9, 1))
    offset = draw(st.sampled_from([0.0, 0.0, 0.1, -3.0, 350.0]))
    periodic = draw(st.booleans()) or draw(st.booleans())
    method = "direct" if n <= 256 and draw(st.integers(0, 4)) == 0 else "cg"
    return dict(
        heights=shape * scale + offset,
        dx=10.0 ** draw(st.floats(-6, -1)),
        youngs_modulus=10.0 ** draw(st.floats(4, 10)),
        mean_pressure=10.0 ** draw(st.floats(2, 8)),
        poisson=draw(st.sampled_from([0.5, 0.49, 0.3, 0.0, -0.5])),
        periodic=periodic,
        kernel="spectral" if periodic and draw(st.integers(0, 3)) == 0 else "element",
        method=method,
        tol=draw(st.sampled_from([1e-4, 1e-6, 1e-8, 1e-10, 1e-12])),
        max_iterations=draw(st.sampled_from([3, 30, 2000, 2000])),
    )


def solve_checked(problem: dict) -> roadtex.ContactResult:
    result = roadtex.contact(**problem, raise_on_nonconvergence=False)
    check_contact(result, periodic=problem["periodic"], kernel=problem["kernel"], method=problem["method"],
                  tol=problem["tol"], max_iterations=problem["max_iterations"])
    return result


# --------------------------------------------------------------------------------------------
# contact


@budget(600)
@given(contact_problems(max_n=4096))
def test_contact_is_right_or_says_it_is_not(problem):
    """Every accepted problem returns a checked-correct result or converged=False, never a
    wrong answer flagged converged."""
    solve_checked(problem)


@budget(40)
@given(contact_problems(max_n=256), st.data())
def test_contact_raise_on_nonconvergence_matches_the_flag(problem, data):
    """With the default raise_on_nonconvergence=True a call raises ConvergenceError exactly when
    the same call with False returns converged=False."""
    quiet = roadtex.contact(**problem, raise_on_nonconvergence=False)
    if quiet.converged:
        loud = roadtex.contact(**problem)
        assert np.array_equal(loud.pressure, quiet.pressure)
    else:
        with pytest.raises(roadtex.ConvergenceError, match=r"stopped after \d+ iterations"):
            roadtex.contact(**problem)


@budget(150)
@given(shapes(max_n=256), st.floats(-300, 300), st.floats(-300, 300), st.floats(-300, 300), st.floats(-300, 300),
       st.booleans())
def test_absurd_magnitudes_raise_a_value_error_or_are_right(shape, log_scale, log_dx, log_e, log_p, periodic):
    """Heights, dx, E and P anywhere in 1e-300 .. 1e300 (SI), CG: a ValueError with a message, or
    a checked result. (Up to 1e+-40 each, every combination solves; beyond about 1e+-100 the
    core under- or overflows: fuzz finding F1, which the binding turns into a ValueError.)"""
    problem = dict(heights=shape * 10.0**log_scale, dx=10.0**log_dx, youngs_modulus=10.0**log_e,
                   mean_pressure=10.0**log_p, periodic=periodic, tol=1e-8, max_iterations=500)
    try:
        result = roadtex.contact(**problem, raise_on_nonconvergence=False)
    except ValueError as exc:
        assert str(exc).strip()
        return
    # Pressures near the edge of what the core accepts lose digits: the core's last guard lets
    # through a load balance to 1e-9 (src/solver/mod.rs, check_solution).
    check_contact(result, periodic=periodic, tol=1e-8, max_iterations=500, beyond_numpy=True, load_balance=1e-9)


def test_f1_heights_spanning_1e160_m_raise_instead_of_nan_flagged_converged():
    """Fuzz finding F1 (tests/fuzz_regressions.rs): heights spanning 1e160 m made the CG solver
    return NaN pressure flagged converged with residual 0. The core now refuses such magnitudes."""
    heights = np.zeros(64)
    heights[1] = -1e160
    with pytest.raises(ValueError, match="heights reach 1e160 m"):
        roadtex.contact(heights, 1e-4, 2.5e6, 2e5)
    with pytest.raises(ValueError, match=r"segment 1.*heights reach"):
        roadtex.contact_many(np.stack([np.zeros(64), heights]), 1e-4, [2.5e6], 2e5)


def test_f2_direct_solve_on_absurd_magnitudes_is_refused():
    """Fuzz finding F2: dx = 1e-300 m, P = 1e-300 Pa made the dense direct solve fail with
    'the trial contact set became empty'; the core now refuses dx outside 1e-40 to 1e40 m."""
    heights = 1e-4 * (np.cos(np.arange(64) * 0.7) + 0.3 * np.sin(np.arange(64) * 2.1))
    with pytest.raises(ValueError, match="dx = 1e-300 m is outside"):
        roadtex.contact(heights, 1e-300, 1.0, 1e-300, method="direct")


@budget(60)
@given(contact_problems(max_n=512), st.data())
def test_drop_outs_and_overflow_raise_a_clear_value_error(problem, data):
    """A NaN (a drop-out) or inf anywhere in the heights raises ValueError naming the heights,
    the value and its index; nothing is solved."""
    heights = problem["heights"].copy()
    index = data.draw(st.integers(0, heights.size - 1))
    bad = data.draw(st.sampled_from([np.nan, np.inf, -np.inf]))
    heights[index] = bad
    problem["heights"] = heights
    with pytest.raises(ValueError, match=rf"(?i)heights.*non-finite.*{re.escape(str(bad))}.*index {index}"):
        roadtex.contact(**problem)


BAD_NUMBERS = [0.0, -1.0, -1e-300, np.nan, np.inf, -np.inf]


@budget(60)
@given(contact_problems(max_n=64), st.sampled_from(["dx", "youngs_modulus", "mean_pressure"]),
       st.sampled_from(BAD_NUMBERS))
def test_bad_parameters_raise_a_value_error_naming_them(problem, name, value):
    """A zero, negative, NaN or infinite dx, E or P raises ValueError naming the argument."""
    problem[name] = value
    with pytest.raises(ValueError, match=name):
        roadtex.contact(**problem)


@budget(25)
@given(st.lists(contact_problems(max_n=128), min_size=1, max_size=3),
       st.lists(st.floats(4, 10), min_size=1, max_size=3), st.sampled_from([1, 2]))
def test_contact_many_results_are_each_checked_and_equal_one_by_one(problems, log_moduli, threads):
    """contact_many on random segments of one length and grid: every (segment, modulus) result
    passes the same check, and equals the one-by-one contact call bitwise."""
    first = problems[0]
    n = first["heights"].size
    segments = np.stack([np.resize(p["heights"], n) for p in problems])
    moduli = [10.0**e for e in log_moduli]
    options = {k: first[k] for k in ("poisson", "periodic", "kernel", "method", "tol", "max_iterations")}
    batch = roadtex.contact_many(segments, first["dx"], moduli, first["mean_pressure"], threads=threads,
                                 raise_on_nonconvergence=False, **options)
    for s in range(segments.shape[0]):
        for m, e in enumerate(moduli):
            result = batch[s, m]
            check_contact(result, periodic=options["periodic"], kernel=options["kernel"], method=options["method"],
                          tol=options["tol"], max_iterations=options["max_iterations"])
            single = roadtex.contact(segments[s], first["dx"], e, first["mean_pressure"], raise_on_nonconvergence=False,
                                     **options)
            assert np.array_equal(single.pressure, result.pressure) and single.residual == result.residual


# --------------------------------------------------------------------------------------------
# the other public functions


@budget(80)
@given(shapes(min_n=3, max_n=4096), st.floats(-9, 0), st.sampled_from([0.0, 0.5, 54.0, 1e3, 1e6]),
       st.floats(-6, -2))
def test_von_meier_is_the_least_envelope_of_bounded_curvature(shape, log_scale, d_star, log_dx):
    """von_meier: e >= z, e == z at both ends, curvature <= 2 d* (to rounding); e is its own
    envelope (least: nothing lower satisfies the limit) and falls as d* rises."""
    z, dx = shape * 10.0**log_scale, 10.0**log_dx
    e = roadtex.von_meier(z, dx, d_star)
    assert e.shape == z.shape and np.all(np.isfinite(e))
    assert np.all(e >= z) and e[0] == z[0] and e[-1] == z[-1]
    c = 2.0 * d_star * dx * dx
    rounding = 64 * np.finfo(float).eps * (np.max(np.abs(z)) + c * z.size**2)
    assert np.max(e[:-2] - 2 * e[1:-1] + e[2:], initial=-np.inf) <= c + rounding
    again = roadtex.von_meier(e, dx, d_star)
    assert np.max(np.abs(again - e)) <= rounding
    lower = roadtex.von_meier(z, dx, 2 * d_star + 1.0)
    assert np.all(lower <= e + rounding)


@budget(30)
@given(contact_problems(max_n=300), st.sampled_from([(16, 4), (64, 16), (1024, 256)]), st.booleans())
def test_clapp_carries_the_load_and_stays_above_the_profile(problem, window, wrap):
    """clapp: a clear ValueError or ClappError (a window whose active set does not settle), or
    finite p >= 0 with mean P, and an envelope >= heights, == heights on contact."""
    sub_profile, overlap = window
    try:
        r = clapp(problem["heights"], problem["dx"], problem["youngs_modulus"], problem["mean_pressure"],
                  poisson=problem["poisson"], sub_profile=sub_profile, overlap=overlap, wrap=wrap)
    except roadtex.errors.ClappError as exc:
        assert "direct solver failed" not in str(exc) and "window" in str(exc), exc
        return
    assert np.all(np.isfinite(r.pressure)) and r.pressure.min() >= 0
    assert abs(r.pressure.mean() / problem["mean_pressure"] - 1) <= LOAD_BALANCE
    assert np.all(r.envelope >= r.heights)
    on = r.pressure > 0
    assert np.array_equal(r.envelope[on], r.heights[on])


@budget(60)
@given(st.lists(shapes(min_n=16, max_n=2048), min_size=1, max_size=3), st.floats(-7, -1),
       st.sampled_from([5e-5, 1e-4, 5e-4, 1e-3]), st.sampled_from(["octave", "third_octave"]))
def test_band_levels_add_up_scale_and_ignore_offsets(rows, log_scale, dx, kind):
    """band_levels (periodic): band mean squares are >= 0, sum to at most the variance
    (Parseval), scale by c^2 with the signal, ignore a constant offset, and NaN input is refused."""
    n = rows[0].size
    signals = np.stack([np.resize(r, n) for r in rows]) * 10.0**log_scale
    levels = band_levels(signals, dx, kind=kind, periodic=True)
    ms = levels.mean_square
    empty = levels.bands["lines"].to_numpy() == 0
    assert np.all(np.isnan(ms[:, empty])) and np.all(ms[:, ~empty] >= 0)
    variance = signals.var(axis=1)
    # Rounding of the FFT: about eps |x| per line, so eps^2 x^2 in power (it shows on constant rows).
    rounding = 1e-24 * float(np.max(signals**2)) * n
    assert np.all(np.nansum(ms, axis=1) <= variance * (1 + 1e-9) + rounding)
    scaled = band_levels(3.0 * signals, dx, kind=kind, periodic=True).mean_square
    np.testing.assert_allclose(scaled[:, ~empty], 9.0 * ms[:, ~empty], rtol=1e-9, atol=1e-12 * variance.max() + 9 * rounding)
    shifted = band_levels(signals + 0.25, dx, kind=kind, periodic=True).mean_square
    offset_rounding = 1e-24 * float(np.max((signals + 0.25) ** 2)) * n
    np.testing.assert_allclose(shifted[:, ~empty], ms[:, ~empty], rtol=1e-6,
                               atol=1e-9 * variance.max() + offset_rounding + rounding)
    broken = signals.copy()
    broken[0, n // 2] = np.nan
    with pytest.raises(ValueError):
        band_levels(broken, dx, kind=kind, periodic=True)


@budget(30)
@given(shapes(min_n=16, max_n=512))
def test_octave_is_the_sum_of_its_three_third_octaves(shape):
    """Each DFT line goes into one band, so an octave's mean square is exactly the sum of its
    three third octaves (to rounding)."""
    dx = 1e-4
    octave = band_levels(shape[None, :] * 1e-3, dx, kind="octave", periodic=True)
    third = band_levels(shape[None, :] * 1e-3, dx, kind="third_octave", periodic=True)
    thirds = dict(zip(third.bands["band"].to_list(), np.nan_to_num(third.mean_square[0])))
    for band, value in zip(octave.bands["band"].to_list(), octave.mean_square[0]):
        parts = [thirds.get(band + k) for k in (-1, 0, 1)]
        if any(p is None for p in parts) or np.isnan(value):
            continue
        assert value == pytest.approx(sum(parts), rel=1e-12, abs=1e-30)


@budget(40)
@given(shapes(min_n=8, max_n=600), st.floats(-6, -2), st.floats(-6, -2), st.sampled_from([0.0, -12.5, 1e3]),
       st.lists(st.integers(0, 599), max_size=5), st.sampled_from(["csv", "tsv", "npy", "parquet"]))
def test_read_profile_gives_back_what_write_profile_wrote(tmp_path_factory, shape, log_dx, log_scale, start,
                                                          dropouts, fmt):
    """Generated profiles (drop-outs as NaN, any scale and start) round-trip through every
    format bit for bit."""
    heights = shape * 10.0**log_scale
    for i in dropouts:
        if i < heights.size:
            heights[i] = np.nan
    assume(not np.isnan(heights).all())
    profile = Profile.from_heights(heights, 10.0**log_dx, start=start)
    path = tmp_path_factory.mktemp("rt") / f"p.{fmt}"
    back = read_profile(write_profile(profile, path))
    assert np.array_equal(back.heights, profile.heights, equal_nan=True)
    assert np.array_equal(back.positions, profile.positions)
    assert back.dx == profile.dx


@budget(60)
@given(st.binary(min_size=0, max_size=400), st.sampled_from([".csv", ".dat", ".txt", ".npy", ".parquet"]))
def test_read_profile_refuses_garbage_with_a_value_error(tmp_path_factory, data, suffix):
    """Arbitrary bytes under any profile suffix: a Profile, or ValueError with a message, never
    another exception."""
    path = tmp_path_factory.mktemp("junk") / f"junk{suffix}"
    path.write_bytes(data)
    try:
        profile = read_profile(path)
    except ValueError as exc:
        assert str(exc).strip()
    else:
        assert profile.heights.size >= 2 and np.all(np.diff(profile.positions) > 0)


@pytest.mark.parametrize("data", [b'"', b"0,1\n0.5,2\n1,\"", b'0,1\n"'])
def test_j1_csv_ending_in_an_open_quote_raises_a_value_error(tmp_path, data):
    """Finding J1: on these polars 2.1 read_csv panics ('slice index starts at 1 but ends at 0');
    read_profile must turn that into a ValueError naming the file, not let a PanicException out."""
    path = tmp_path / "quote.csv"
    path.write_bytes(data)
    with pytest.raises(ValueError):
        read_profile(path)


@budget(40)
@given(st.integers(1, 200), st.floats(0.0, 1.0))
def test_read_profile_on_a_cut_csv_file_refuses_or_reads_a_prefix(tmp_path_factory, rows, fraction):
    """A CSV profile cut at any byte: ValueError, or a prefix of the rows (exact but for the
    last one, which a cut inside its last number shortens; a cut at a line end cannot be told
    from a shorter file)."""
    heights = np.round(np.sin(np.arange(rows + 2) * 0.7) * 1e-3, 6)
    profile = Profile.from_heights(heights, 1e-4)
    path = write_profile(profile, tmp_path_factory.mktemp("cut") / "p.csv")
    data = path.read_bytes()
    path.write_bytes(data[:int(fraction * len(data))])
    try:
        back = read_profile(path)
    except ValueError as exc:
        assert str(exc).strip()
        return
    k = back.heights.size
    assert 2 <= k <= profile.heights.size
    assert np.array_equal(back.heights[:-1], profile.heights[:k - 1])
    assert np.array_equal(back.positions[:-1], profile.positions[:k - 1])
