"""The von Meier envelope through the public API."""

import numpy as np
import pytest

import roadtex
from roadtex.profiles.synthetic import self_affine_profile


def test_envelope_respects_curvature_limit_and_profile():
    """e >= z everywhere, second difference <= 2 d* dx^2, and equality with z at both ends."""
    n, dx, d_star = 4096, 5e-5, 54.0
    z = self_affine_profile(n, n * dx, rms_slope=0.2, seed=5)
    e = roadtex.von_meier(z, dx, d_star)
    assert np.all(e >= z)
    second = (e[:-2] - 2 * e[1:-1] + e[2:]) / dx**2
    assert second.max() <= 2 * d_star * (1 + 1e-9)
    assert e[0] == z[0] and e[-1] == z[-1]
    assert np.count_nonzero(e > z) > 0


def test_lower_curvature_limit_bridges_more():
    """A smaller d* lets the rubber sag less, so it stays higher above the valleys."""
    n, dx = 2048, 5e-5
    z = self_affine_profile(n, n * dx, rms_slope=0.2, seed=6)
    stiff = roadtex.von_meier(z, dx, 10.0)
    soft = roadtex.von_meier(z, dx, 500.0)
    assert np.all(stiff >= soft - 1e-15)
    assert (stiff - z).mean() > (soft - z).mean()


@pytest.mark.parametrize("bad, match", [
    (dict(heights=[0.0, np.nan, 0.0, 0.0]), "non-finite"),
    (dict(heights=[0.0, 1.0]), "at least 3"),
    (dict(dx=0.0), "dx must be"),
    (dict(d_star=-1.0), "d_star"),
])
def test_bad_input_is_named(bad, match):
    """Bad input raises ValueError naming the problem."""
    args = dict(heights=np.zeros(16), dx=1e-4, d_star=54.0) | bad
    with pytest.raises(ValueError, match=match):
        roadtex.von_meier(**args)
