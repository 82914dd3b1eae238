"""The library's functions against what a caller may do (issue 29): fork after a warm-up call,
absurd thread counts, masked arrays, mixed band tables, extreme magnitudes, wrongly typed
arguments."""

from __future__ import annotations

import multiprocessing

import numpy as np
import pytest

import roadtex
from roadtex._checks import MIN_THREAD_LIMIT, THREADS_PER_CORE_LIMIT, usable_cores
from roadtex.errors import InvalidInputError
from roadtex.profiles.pavements import synthetic_pavement

DX = 5e-4
SEGMENTS = np.stack([synthetic_pavement("dense_asphalt", 0.6, DX, seed=i).heights[:1024] for i in range(4)])


def solve_lines(_: int) -> list[bool]:
    return roadtex.contact_many(SEGMENTS, DX, youngs_modulus=[1e7], mean_pressure=2e5, tol=1e-6).converged.ravel().tolist()


def solve_tiles(_: int) -> list[bool]:
    tiles = np.random.default_rng(0).normal(0.0, 3e-4, (2, 32, 32))
    return roadtex.contact_surface_many(tiles, DX, DX, youngs_modulus=[1e7], mean_pressure=2e5,
                                        tol=1e-6).converged.ravel().tolist()


def solve_clapp(_: int) -> int:
    return int(roadtex.clapp(SEGMENTS[0], DX, 1e7, 2e5).envelope.size)


@pytest.mark.parametrize("work", [solve_lines, solve_tiles, solve_clapp], ids=lambda f: f.__name__)
def test_a_child_forked_after_a_warm_up_call_does_not_hang(work) -> None:
    solve_lines(0)   # the parent's warm-up starts rayon's global pool
    expected = work(0)
    with multiprocessing.get_context("fork").Pool(1) as pool:
        assert pool.map_async(work, [0]).get(timeout=60) == [expected]


def test_thread_counts_beyond_the_limit_are_refused_before_any_work(monkeypatch: pytest.MonkeyPatch) -> None:
    limit = max(MIN_THREAD_LIMIT, THREADS_PER_CORE_LIMIT * usable_cores())
    # the solver's entry points counted, not the time taken: "before any work" is no call into the core
    calls: list[str] = []
    for name in ("solve_many", "solve_surface_many"):
        original = getattr(roadtex._core, name)
        monkeypatch.setattr(roadtex._core, name,
                            lambda *a, _name=name, _original=original, **k: calls.append(_name) or _original(*a, **k))
    with pytest.raises(InvalidInputError, match=rf"threads = 10000 is more than {limit} "):
        roadtex.contact_many(SEGMENTS, DX, youngs_modulus=[1e7], mean_pressure=2e5, threads=10_000)
    with pytest.raises(InvalidInputError, match=rf"threads = {limit + 1} is more than {limit} "):
        roadtex.contact_surface_many(SEGMENTS[:, None, :64].repeat(8, axis=1), DX, DX, youngs_modulus=[1e7],
                                     mean_pressure=2e5, threads=limit + 1)
    assert calls == []
    at_limit = roadtex.contact_many(SEGMENTS, DX, youngs_modulus=[1e7], mean_pressure=2e5, tol=1e-6, threads=limit)
    one = roadtex.contact_many(SEGMENTS, DX, youngs_modulus=[1e7], mean_pressure=2e5, tol=1e-6, threads=1)
    assert np.array_equal(at_limit.pressure, one.pressure)


def test_masked_values_are_refused_by_the_solvers_and_drop_outs_in_a_profile() -> None:
    heights = np.ma.masked_less(np.where(np.arange(1024) % 100 == 7, -0.85, SEGMENTS[0]), -0.5)
    assert np.ma.count_masked(heights) == 11
    with pytest.raises(InvalidInputError, match=r"heights is a masked array with 11 masked value\(s\)"):
        roadtex.contact(heights, DX, 1e7, 2e5)
    with pytest.raises(InvalidInputError, match=r"segments is a masked array"):
        roadtex.contact_many(np.ma.stack([heights, heights]), DX, youngs_modulus=[1e7], mean_pressure=2e5)
    profile = roadtex.Profile.from_heights(heights, DX)
    assert np.isnan(profile.heights).sum() == 11 and np.nanmin(profile.heights) > -0.5
    unmasked = np.ma.masked_array(SEGMENTS[0], mask=False)   # nothing masked: taken as it is
    assert roadtex.contact(unmasked, DX, 1e7, 2e5).converged


def test_complex_heights_and_text_or_boolean_numbers_are_refused() -> None:
    with pytest.raises(InvalidInputError, match=r"heights must be real numbers, got complex values"):
        roadtex.contact(SEGMENTS[0] + 1e-9j, DX, 1e7, 2e5)
    with pytest.raises(InvalidInputError, match=r"heights must be real numbers"):
        roadtex.Profile.from_heights(SEGMENTS[0].astype(complex), DX)
    for dx in ("1e-4", True):
        with pytest.raises(InvalidInputError, match=rf"dx must be a number, got {dx!r}"):
            roadtex.contact(SEGMENTS[0], dx, 1e7, 2e5)


def test_level_differences_refuse_other_band_kinds_and_other_sampling() -> None:
    signal = SEGMENTS[:1]
    third = roadtex.band_levels(signal, DX, kind="third_octave", periodic=True).to_frame()
    octave = roadtex.band_levels(signal, DX, kind="octave", periodic=True).to_frame()
    coarse = roadtex.band_levels(signal[:, ::2], 2 * DX, kind="third_octave", periodic=True).to_frame()
    assert roadtex.level_differences(third, third)["level_difference_db"].drop_nans().abs().max() == 0.0
    with pytest.raises(InvalidInputError, match=r"other band edges \(octave against third-octave"):
        roadtex.level_differences(octave, third)
    with pytest.raises(InvalidInputError, match=r"other numbers of DFT lines"):
        roadtex.level_differences(third, coarse)


@pytest.mark.parametrize("scale", [1e200, 1e-300])
def test_band_levels_of_extreme_magnitudes_are_refused_not_inf_or_nan(scale: float) -> None:
    signal = SEGMENTS[:1] / np.abs(SEGMENTS[:1]).max() * scale
    with pytest.raises(InvalidInputError, match=r"values reach at most .* would (overflow|underflow) float64"):
        roadtex.band_levels(signal, DX, reference=scale)
    # within the range, a scaled signal with a scaled reference gives the same levels
    levels = roadtex.band_levels(SEGMENTS[:1], DX, reference=1e-6).levels
    scaled = roadtex.band_levels(SEGMENTS[:1] * 1e100, DX, reference=1e-6 * 1e100).levels
    assert np.allclose(levels, scaled, equal_nan=True, atol=1e-9)
