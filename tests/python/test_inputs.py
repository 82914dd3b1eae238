"""Input validation and non-convergence handling of roadtex.contact and roadtex.contact_many.

Every bad input must raise ValueError with a message that names the argument and the problem.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import roadtex
from roadtex.profiles.synthetic import self_affine_profile

N = 64
DX = 1e-4
E = 2.5e6
P = 2e5


def good_heights(n: int = N) -> np.ndarray:
    """A smooth wavy profile (m)."""
    return 1e-4 * np.cos(2.0 * np.pi * np.arange(n) / n)


def with_value(value: float, index: int = 5) -> np.ndarray:
    heights = good_heights()
    heights[index] = value
    return heights


def call_contact(**overrides):
    args = dict(heights=good_heights(), dx=DX, youngs_modulus=E, mean_pressure=P)
    args.update(overrides)
    return roadtex.contact(**args)


def call_many(**overrides):
    args = dict(segments=np.stack([good_heights(), 0.5 * good_heights()]), dx=DX, youngs_modulus=[E, 2 * E],
                mean_pressure=P)
    args.update(overrides)
    return roadtex.contact_many(**args)


# (overrides, regex the message must match)
CONTACT_CASES = {
    "nan height": (dict(heights=with_value(np.nan)), r"(?i)heights.*non-finite.*nan.*index 5"),
    "inf height": (dict(heights=with_value(np.inf)), r"heights.*non-finite.*inf.*index 5"),
    "-inf height": (dict(heights=with_value(-np.inf, index=0)), r"heights.*non-finite.*-inf.*index 0"),
    "empty": (dict(heights=np.array([])), r"heights.*empty"),
    "empty list": (dict(heights=[]), r"heights.*empty"),
    "7 points": (dict(heights=good_heights(7)), r"heights has 7 points.*at least 8"),
    "1 point": (dict(heights=[0.0]), r"heights has 1 points.*at least 8"),
    "2-D heights": (dict(heights=good_heights().reshape(8, 8)), r"heights must be a 1-D array.*\(8, 8\)"),
    "scalar heights": (dict(heights=1.0), r"heights must be a 1-D array"),
    "text heights": (dict(heights=["a"] * 10), r"heights must be numeric"),
    "dx zero": (dict(dx=0.0), r"dx must be a positive"),
    "dx negative": (dict(dx=-1e-4), r"dx must be a positive"),
    "dx nan": (dict(dx=float("nan")), r"dx must be a positive finite"),
    "dx inf": (dict(dx=float("inf")), r"dx must be a positive finite"),
    "dx text": (dict(dx="abc"), r"dx must be a number"),
    "E zero": (dict(youngs_modulus=0.0), r"youngs_modulus must be a positive"),
    "E negative": (dict(youngs_modulus=-2.5e6), r"youngs_modulus must be a positive"),
    "E inf": (dict(youngs_modulus=float("inf")), r"youngs_modulus must be a positive finite"),
    "E nan": (dict(youngs_modulus=float("nan")), r"youngs_modulus must be a positive finite"),
    "P zero": (dict(mean_pressure=0.0), r"mean_pressure must be a positive"),
    "P negative": (dict(mean_pressure=-2e5), r"mean_pressure must be a positive"),
    "P nan": (dict(mean_pressure=float("nan")), r"mean_pressure must be a positive finite"),
    "poisson -1": (dict(poisson=-1.0), r"poisson must lie in \(-1, 0\.5\]"),
    "poisson 0.6": (dict(poisson=0.6), r"poisson must lie in \(-1, 0\.5\]"),
    "poisson 0.5000001": (dict(poisson=0.5000001), r"poisson must lie in \(-1, 0\.5\]"),
    "poisson nan": (dict(poisson=float("nan")), r"poisson must lie in"),
    "kernel": (dict(kernel="gauss"), r"kernel must be 'element' or 'spectral'.*gauss"),
    "kernel case": (dict(kernel="Element"), r"kernel must be 'element' or 'spectral'"),
    "method": (dict(method="lu"), r"method must be 'cg' or 'direct'.*lu"),
    "direct too large": (dict(heights=good_heights(8193), method="direct"), r"method='direct'.*8192.*8193"),
    "tol zero": (dict(tol=0.0), r"tol must lie in \(0, 1\)"),
    "tol one": (dict(tol=1.0), r"tol must lie in \(0, 1\)"),
    "tol negative": (dict(tol=-1e-6), r"tol must lie in \(0, 1\)"),
    "tol nan": (dict(tol=float("nan")), r"tol must lie in \(0, 1\)"),
    "max_iterations 0": (dict(max_iterations=0), r"max_iterations must be at least 1"),
    "max_iterations negative": (dict(max_iterations=-1), r"max_iterations"),
}


@pytest.mark.parametrize("case", list(CONTACT_CASES))
def test_contact_rejects_bad_input(case):
    """contact(): each bad input raises ValueError naming the argument and the problem."""
    overrides, message = CONTACT_CASES[case]
    with pytest.raises(ValueError, match=message):
        call_contact(**overrides)


MANY_CASES = {
    "1-D segments": (dict(segments=good_heights()), r"segments must be a 2-D array.*\(64,\)"),
    "3-D segments": (dict(segments=good_heights().reshape(1, 8, 8)), r"segments must be a 2-D array"),
    "ragged rows": (dict(segments=[list(range(8)), list(range(9))]), r"segments must be numeric"),
    "no rows": (dict(segments=np.zeros((0, N))), r"segments is empty"),
    "empty rows": (dict(segments=np.zeros((2, 0))), r"segments is empty"),
    "7-point rows": (dict(segments=np.zeros((2, 7))), r"segment 0: heights has 7 points.*at least 8"),
    "nan in row 1": (dict(segments=np.stack([good_heights(), with_value(np.nan, 3)])),
                     r"(?i)segment 1: heights.*non-finite.*nan.*index 3"),
    "inf in row 0": (dict(segments=np.stack([with_value(np.inf), good_heights()])), r"segment 0: .*non-finite.*inf"),
    "no moduli": (dict(youngs_modulus=[]), r"youngs_modulus is empty"),
    "2-D moduli": (dict(youngs_modulus=[[E]]), r"youngs_modulus must be a number or a 1-D sequence"),
    "negative modulus": (dict(youngs_modulus=[E, -1.0]), r"youngs_modulus must be a positive"),
    "nan modulus": (dict(youngs_modulus=[np.nan]), r"youngs_modulus must be a positive finite"),
    "dx zero": (dict(dx=0.0), r"dx must be a positive"),
    "P zero": (dict(mean_pressure=0.0), r"mean_pressure must be a positive"),
    "poisson 0.6": (dict(poisson=0.6), r"poisson must lie in \(-1, 0\.5\]"),
    "kernel": (dict(kernel="fft"), r"kernel must be 'element' or 'spectral'"),
    "method": (dict(method="qr"), r"method must be 'cg' or 'direct'"),
    "direct too large": (dict(segments=np.zeros((1, 9000)), method="direct"), r"method='direct'.*8192"),
    "tol one": (dict(tol=1.0), r"tol must lie in \(0, 1\)"),
    "threads zero": (dict(threads=0), r"threads must be at least 1"),
}


@pytest.mark.parametrize("case", list(MANY_CASES))
def test_contact_many_rejects_bad_input(case):
    """contact_many(): each bad input raises ValueError naming the argument and the problem."""
    overrides, message = MANY_CASES[case]
    with pytest.raises(ValueError, match=message):
        call_many(**overrides)


def test_spectral_kernel_needs_periodic_model():
    """kernel='spectral' with periodic=False is refused with a message naming both."""
    with pytest.raises(ValueError, match=r"kernel='spectral'.*periodic"):
        call_contact(kernel="spectral", periodic=False)


# --------------------------------------------------------------------------------------------
# accepted input forms


def test_list_and_float32_and_strided_inputs_are_accepted():
    """Lists, float32 and non-contiguous views give the same result as a float64 array."""
    base = good_heights(128)
    reference = roadtex.contact(base, DX, E, P)
    as_list = roadtex.contact(base.tolist(), DX, E, P)
    assert np.array_equal(as_list.pressure, reference.pressure)
    strided_source = np.repeat(base, 2)
    strided = roadtex.contact(strided_source[::2], DX, E, P)
    assert np.array_equal(strided.pressure, reference.pressure)
    as_float32 = roadtex.contact(base.astype(np.float32), DX, E, P)
    assert as_float32.converged and as_float32.pressure.dtype == np.float64
    assert np.max(np.abs(as_float32.pressure - reference.pressure)) / P <= 1e-4
    for result in (reference, as_float32):
        assert abs(result.pressure.mean() / P - 1.0) <= 1e-12
        assert result.pressure.min() >= 0.0
        assert np.all(result.envelope >= result.heights)


def test_input_is_not_modified():
    """The caller's heights array is left untouched."""
    heights = good_heights(128)
    copy = heights.copy()
    roadtex.contact(heights, DX, E, P)
    assert np.array_equal(heights, copy)


# --------------------------------------------------------------------------------------------
# non-convergence


def rough_profile() -> tuple[np.ndarray, float]:
    """A rough road-like profile that needs many CG iterations."""
    n = 1024
    return self_affine_profile(n, 0.1, rms_slope=0.2, seed=1), 0.1 / n


def test_nonconvergence_raises():
    """max_iterations=1 on a rough profile raises ConvergenceError (a RuntimeError) that says why."""
    heights, dx = rough_profile()
    with pytest.raises(roadtex.ConvergenceError, match=r"stopped after \d+ iterations at residual .* > tol"):
        roadtex.contact(heights, dx, E, P, max_iterations=1)
    assert issubclass(roadtex.ConvergenceError, RuntimeError)


def test_nonconvergence_can_return_result():
    """With raise_on_nonconvergence=False the unconverged result comes back flagged, still
    carrying the load with p >= 0."""
    heights, dx = rough_profile()
    result = roadtex.contact(heights, dx, E, P, max_iterations=1, raise_on_nonconvergence=False, tol=1e-10)
    assert result.converged is False
    assert result.iterations == 1, f"max_iterations=1 but {result.iterations} iterations reported"
    assert result.residual > 1e-10
    assert result.pressure.min() >= 0.0
    assert abs(result.pressure.mean() / P - 1.0) <= 1e-12


def test_contact_many_nonconvergence():
    """contact_many raises ConvergenceError when any problem fails, or flags each one with
    raise_on_nonconvergence=False."""
    heights, dx = rough_profile()
    segments = np.stack([heights, np.roll(heights, 100)])
    with pytest.raises(roadtex.ConvergenceError, match=r"did not reach tol"):
        roadtex.contact_many(segments, dx, [E, 4 * E], P, max_iterations=1)
    batch = roadtex.contact_many(segments, dx, [E, 4 * E], P, max_iterations=1, raise_on_nonconvergence=False)
    assert batch.converged.shape == (2, 2)
    assert not batch.converged.any()
    assert np.all(batch.iterations == 1), f"max_iterations=1 but iterations {batch.iterations.tolist()}"
    assert np.all(batch.residual > 1e-10)


@pytest.mark.parametrize("call", ["contact", "contact_many", "contact_surface", "clapp"])
def test_moduli_and_pressures_in_mpa_are_warned_about_in_every_solver(call: str) -> None:
    """E = 2.5 and P = 0.2 (MPa given where Pa are expected): each solver warns, naming the value."""
    from roadtex.errors import ImplausibleParameterWarning

    z = roadtex.synthetic_pavement("dense_asphalt", 0.064, 0.5e-3, seed=1).heights
    solvers = {
        "contact": lambda e, p: roadtex.contact(z, 0.5e-3, e, p),
        "contact_many": lambda e, p: roadtex.contact_many(z[None, :], 0.5e-3, [e], p),
        "contact_surface": lambda e, p: roadtex.contact_surface(np.tile(z[:32], (8, 1)), 0.5e-3,
                                                                youngs_modulus=e, mean_pressure=p),
        "clapp": lambda e, p: roadtex.clapp(z, 0.5e-3, e, p),
    }
    with pytest.warns(ImplausibleParameterWarning, match="youngs_modulus = 2.5 Pa"):
        solvers[call](2.5, 2e5)
    with pytest.warns(ImplausibleParameterWarning, match="mean_pressure = 0.2 Pa"):
        solvers[call](2.5e6, 0.2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleParameterWarning)
        solvers[call](2.5e6, 2e5)  # plausible: silent


@pytest.mark.parametrize(("call", "match"), [
    (lambda: roadtex.reference.westergaard_contact_half_width(1e-4, -0.02, 2e6, 1e4), "wavelength"),
    (lambda: roadtex.reference.westergaard_element_pressure(np.zeros(4), 0.0, 1e-4, 0.02, 2e6, 1e4), "dx"),
    (lambda: roadtex.reference.westergaard_full_contact_pressure(1e-4, 0.0, 2e6), "wavelength"),
    (lambda: roadtex.reference.flat_punch_element_pressure(np.zeros(4), 1e-3, -0.01, 1e5), "width"),
    (lambda: roadtex.reference.flat_punch_element_pressure([0.0, np.nan], 1e-3, 0.01, 1e5), "finite"),
    (lambda: roadtex.reference.hertz_sphere(np.zeros(3), 0.05, -1.0, 1e6), "force"),
    (lambda: roadtex.reference.bisinusoid_full_contact_pressure(1e-4, 0.01, 0.01, float("nan")), "plane_strain"),
], ids=["half-width", "element dx", "p*", "punch width", "punch x", "hertz force", "bisinusoid E*"])
def test_closed_forms_refuse_bad_input_naming_the_argument(call, match: str) -> None:
    """The closed-form references are public: a bad argument is an InvalidInputError naming it,
    never a NaN, a complex number, a ZeroDivisionError or a Rust panic."""
    with pytest.raises(roadtex.InvalidInputError, match=match):
        call()


def test_closed_forms_keep_the_shape_of_their_positions() -> None:
    x = np.linspace(0.0, 0.02, 12).reshape(3, 4)
    p = roadtex.reference.westergaard_element_pressure(x, 0.02 / 12, 1e-4, 0.02, 2e6, 1e4)
    assert p.shape == (3, 4)
    np.testing.assert_array_equal(p.ravel(), roadtex.reference.westergaard_element_pressure(
        x.ravel(), 0.02 / 12, 1e-4, 0.02, 2e6, 1e4))
