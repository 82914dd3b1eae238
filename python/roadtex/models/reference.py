"""Closed-form reference solutions for tests and benchmarks (SI units)."""

from __future__ import annotations

import math

import numpy as np

from roadtex import _core
from roadtex._checks import as_float_array, finite_number, positive, positive_int
from roadtex.errors import InvalidInputError


def _positions(x: object) -> np.ndarray:
    """Finite positions (m) of any shape, flattened for the Rust core."""
    values = as_float_array(np.ravel(x), "x", 1)
    if not np.isfinite(values).all():
        raise InvalidInputError("x must hold finite positions (m)")
    return values


def westergaard_profile(n: int, wavelength: float, amplitude: float) -> tuple[np.ndarray, float]:
    """Heights A cos(2 pi x / L) (m) at the N element centres x = i dx of one wavelength; returns (heights, dx)."""
    n = positive_int(n, "n")
    wavelength = positive(wavelength, "wavelength")
    amplitude = finite_number(amplitude, "amplitude")
    dx = wavelength / n
    x = np.arange(n) * dx
    return amplitude * np.cos(2.0 * np.pi * x / wavelength), dx


def westergaard_full_contact_pressure(amplitude: float, wavelength: float, plane_strain_modulus: float) -> float:
    """p* = pi E* A / L (Pa): the mean pressure that closes every gap of the wavy surface."""
    amplitude, wavelength = positive(amplitude, "amplitude"), positive(wavelength, "wavelength")
    plane_strain_modulus = positive(plane_strain_modulus, "plane_strain_modulus", "Pa")
    return math.pi * plane_strain_modulus * amplitude / wavelength


def westergaard_contact_half_width(amplitude: float, wavelength: float, plane_strain_modulus: float,
                                   mean_pressure: float) -> float:
    """Half-width a (m) of contact around each crest: sin^2(pi a / L) = P / p*."""
    return _core.westergaard_contact_half_width(*_westergaard_arguments(amplitude, wavelength, plane_strain_modulus,
                                                                        mean_pressure))


def _westergaard_arguments(amplitude: float, wavelength: float, plane_strain_modulus: float,
                           mean_pressure: float) -> tuple[float, float, float, float]:
    return (positive(amplitude, "amplitude"), positive(wavelength, "wavelength"),
            positive(plane_strain_modulus, "plane_strain_modulus", "Pa"), positive(mean_pressure, "mean_pressure", "Pa"))


def westergaard_element_pressure(x: np.ndarray, dx: float, amplitude: float, wavelength: float,
                                 plane_strain_modulus: float, mean_pressure: float) -> np.ndarray:
    """Exact Westergaard pressure averaged over each element [x - dx/2, x + dx/2] (Pa)."""
    positions = _positions(x)
    pressure = _core.westergaard_element_pressure(positions, positive(dx, "dx"),
                                                  *_westergaard_arguments(amplitude, wavelength, plane_strain_modulus,
                                                                          mean_pressure))
    return pressure.reshape(np.shape(x))


def flat_punch_element_pressure(x: np.ndarray, dx: float, width: float, mean_pressure: float) -> np.ndarray:
    """Rigid flat punch of width L on a half-space, p = P L / (pi sqrt(x (L - x))), averaged per element (Pa)."""
    positions = _positions(x)
    pressure = _core.flat_punch_element_pressure(positions, positive(dx, "dx"), positive(width, "width"),
                                                 positive(mean_pressure, "mean_pressure", "Pa"))
    return pressure.reshape(np.shape(x))


def bisinusoid_full_contact(x: np.ndarray, y: np.ndarray, amplitude: float, wavelength_x: float, wavelength_y: float,
                            plane_strain_modulus: float, mean_pressure: float) -> np.ndarray:
    """Pressure (Pa) on the surface z = A cos(2 pi x / Lx) cos(2 pi y / Ly) in full contact.

    In full contact the rubber surface follows z, and each Fourier mode of the displacement is
    2 / (E* |k|) times that of the pressure (Boussinesq), so p = P + E* |k| z / 2 with
    |k| = 2 pi sqrt(1 / Lx^2 + 1 / Ly^2) (Johnson, Greenwood & Higginson 1985). It holds while
    p >= 0 everywhere, i.e. for ``mean_pressure`` at least
    :func:`bisinusoid_full_contact_pressure`.

    Args:
        x, y: positions (m), broadcast against each other (e.g. from ``np.meshgrid``).
        amplitude: A (m); wavelength_x, wavelength_y: Lx, Ly (m).
        plane_strain_modulus: E* (Pa); mean_pressure: P (Pa).
    """
    amplitude = finite_number(amplitude, "amplitude")
    wavelength_x, wavelength_y = positive(wavelength_x, "wavelength_x"), positive(wavelength_y, "wavelength_y")
    plane_strain_modulus = positive(plane_strain_modulus, "plane_strain_modulus", "Pa")
    mean_pressure = positive(mean_pressure, "mean_pressure", "Pa")
    k = 2.0 * math.pi * math.hypot(1.0 / wavelength_x, 1.0 / wavelength_y)
    z = amplitude * np.cos(2.0 * np.pi * np.asarray(x) / wavelength_x) * np.cos(2.0 * np.pi * np.asarray(y) / wavelength_y)
    return mean_pressure + 0.5 * plane_strain_modulus * k * z


def bisinusoid_full_contact_pressure(amplitude: float, wavelength_x: float, wavelength_y: float,
                                     plane_strain_modulus: float) -> float:
    """The least mean pressure (Pa) that keeps the bi-sinusoidal surface in full contact: E* |k| A / 2."""
    amplitude = positive(amplitude, "amplitude")
    wavelength_x, wavelength_y = positive(wavelength_x, "wavelength_x"), positive(wavelength_y, "wavelength_y")
    plane_strain_modulus = positive(plane_strain_modulus, "plane_strain_modulus", "Pa")
    return 0.5 * plane_strain_modulus * 2.0 * math.pi * math.hypot(1.0 / wavelength_x, 1.0 / wavelength_y) * amplitude


def hertz_sphere(r: np.ndarray, radius: float, force: float, plane_strain_modulus: float) -> tuple[np.ndarray, float]:
    """Hertz's sphere on a half-space: the pressure (Pa) at distances r (m) from the axis, and the
    contact radius a (m) = (3 F R / (4 E*))^(1/3); p = 3 F / (2 pi a^2) sqrt(1 - r^2 / a^2) inside.

    Args:
        r: distances from the axis (m). radius: the sphere's radius R (m). force: F (N).
        plane_strain_modulus: E* (Pa).
    """
    radius, force = positive(radius, "radius"), positive(force, "force", "N")
    plane_strain_modulus = positive(plane_strain_modulus, "plane_strain_modulus", "Pa")
    a = (3.0 * force * radius / (4.0 * plane_strain_modulus)) ** (1.0 / 3.0)
    p0 = 3.0 * force / (2.0 * math.pi * a * a)
    rr = np.asarray(r, dtype=np.float64)
    return p0 * np.sqrt(np.clip(1.0 - (rr / a) ** 2, 0.0, None)), a
