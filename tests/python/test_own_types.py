"""The API takes the library's own types wherever it takes heights and a spacing (issue 38):
``roadtex.contact(profile, youngs_modulus=..., mean_pressure=...)`` failed with "missing 1 required
positional argument: 'dx'". A Profile carries its dx and a Surface its dx and dy; a spacing given
with one must be the one it carries; the results equal those of the array with its spacing."""

from __future__ import annotations

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex import Profile, Surface
from roadtex.errors import InvalidInputError

PROFILE = roadtex.synthetic_pavement("dense_asphalt", 0.256, 0.5e-3, seed=4)
SURFACE = roadtex.synthetic_surface("dense_asphalt", 0.064, 0.016, 1e-3, seed=4)
E, P = 2.5e6, 2e5


def test_contact_takes_a_profile() -> None:
    given = roadtex.contact(PROFILE, youngs_modulus=E, mean_pressure=P)
    expected = roadtex.contact(PROFILE.heights, PROFILE.dx, E, P)
    np.testing.assert_array_equal(given.pressure, expected.pressure)
    assert given.dx == PROFILE.dx
    same = roadtex.contact(PROFILE, PROFILE.dx, E, P, periodic=False)   # its own dx, given: fine
    np.testing.assert_array_equal(same.pressure, roadtex.contact(PROFILE.heights, PROFILE.dx, E, P, periodic=False).pressure)


def test_the_spectra_and_the_envelope_take_a_profile() -> None:
    for function in (roadtex.third_octave_levels, roadtex.octave_levels):
        assert function(PROFILE).equals(function(PROFILE.heights, PROFILE.dx))
    levels = roadtex.band_levels(PROFILE)
    np.testing.assert_array_equal(levels.levels, roadtex.band_levels(PROFILE.heights[None, :], PROFILE.dx).levels)
    np.testing.assert_array_equal(roadtex.von_meier(PROFILE), roadtex.von_meier(PROFILE.heights, PROFILE.dx))


def test_contact_surface_takes_a_surface() -> None:
    given = roadtex.contact_surface(SURFACE, youngs_modulus=E, mean_pressure=P)
    expected = roadtex.contact_surface(SURFACE.heights, SURFACE.dx, SURFACE.dy, youngs_modulus=E, mean_pressure=P)
    np.testing.assert_array_equal(given.pressure, expected.pressure)
    assert (given.dx, given.dy) == (SURFACE.dx, SURFACE.dy)


def test_a_spacing_that_disagrees_with_the_one_carried_is_refused() -> None:
    with pytest.raises(InvalidInputError, match=r"dx 0\.001 m was given for a Profile whose dx is 0\.0005 m"):
        roadtex.contact(PROFILE, 1e-3, E, P)
    with pytest.raises(InvalidInputError, match=r"dx 0\.001 m was given for a Profile"):
        roadtex.third_octave_levels(PROFILE, 1e-3)
    with pytest.raises(InvalidInputError, match=r"dy 0\.002 m was given for a Surface whose dy is 0\.001 m"):
        roadtex.contact_surface(SURFACE, dy=2e-3, youngs_modulus=E, mean_pressure=P)


def test_the_wrong_type_or_a_missing_argument_is_named() -> None:
    with pytest.raises(InvalidInputError, match="heights is a Surface; this function takes a Profile"):
        roadtex.contact(SURFACE, youngs_modulus=E, mean_pressure=P)
    with pytest.raises(InvalidInputError, match="heights is a Profile; this function takes a Surface"):
        roadtex.contact_surface(PROFILE, youngs_modulus=E, mean_pressure=P)
    with pytest.raises(InvalidInputError, match=r"dx \(m\) is required with an array of heights"):
        roadtex.contact(PROFILE.heights, youngs_modulus=E, mean_pressure=P)
    with pytest.raises(InvalidInputError, match=r"mean_pressure \(Pa\) is required"):
        roadtex.contact(PROFILE, youngs_modulus=E)


def test_an_unevenly_spaced_profile_is_refused_not_read_as_even() -> None:
    positions = np.cumsum(np.r_[0.0, np.full(99, 1e-3)])
    positions[50:] += 0.5e-3
    uneven = Profile(np.random.default_rng(1).normal(0, 1e-3, 100), positions, 1e-3)
    with pytest.raises(InvalidInputError, match="not equally spaced"):
        roadtex.third_octave_levels(uneven)
    assert isinstance(roadtex.third_octave_levels(PROFILE), pl.DataFrame) and isinstance(SURFACE, Surface)
