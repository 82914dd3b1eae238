"""The finite (non-periodic) model: a flat profile is the rigid flat punch of width L."""

import numpy as np

import roadtex
from roadtex import reference as ref


def test_flat_profile_converges_to_the_flat_punch():
    """Away from the ends (the middle 80 %) the pressure tends to P L / (pi sqrt(x (L - x)))
    averaged per element, the error falling about as 1/N; the load is exact; the ends carry the
    edge over-pressure (above 9 P) that the periodic model removes."""
    length, pressure, modulus = 0.5, 2e5, 2.5e6
    errors = []
    for n in (256, 1024, 4096):
        dx = length / n
        result = roadtex.contact(np.zeros(n), dx, modulus, pressure, periodic=False, tol=1e-12)
        x = (np.arange(n) + 0.5) * dx
        exact = ref.flat_punch_element_pressure(x, dx, length, pressure)
        middle = (x > 0.1 * length) & (x < 0.9 * length)
        errors.append(np.abs(result.pressure[middle] - exact[middle]).max() / pressure)
        assert abs(result.pressure.mean() / pressure - 1.0) <= 1e-12
        assert result.pressure[0] > 9 * pressure and result.pressure[-1] > 9 * pressure
        periodic = roadtex.contact(np.zeros(n), dx, modulus, pressure)
        assert np.allclose(periodic.pressure, pressure, rtol=1e-12, atol=0)
    assert errors[2] < 5e-4
    assert errors[0] > 3 * errors[1] > 9 * errors[2]
