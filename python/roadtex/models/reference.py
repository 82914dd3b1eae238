"""Closed-form reference solutions for tests and benchmarks (SI units)."""

from __future__ import annotations

import math

import numpy as np

from roadtex import _core


def westergaard_profile(n: int, wavelength: float, amplitude: float) -> tuple[np.ndarray, float]:
    """Heights A cos(2 pi x / L) (m) at the N element centres x = i dx of one wavelength; returns (heights, dx)."""
    dx = wavelength / n
    x = np.arange(n) * dx
    return amplitude * np.cos(2.0 * np.pi * x / wavelength), dx


def westergaard_full_contact_pressure(amplitude: float, wavelength: float, plane_strain_modulus: float) -> float:
    """p* = pi E* A / L (Pa): the mean pressure that closes every gap of the wavy surface."""
    return math.pi * plane_strain_modulus * amplitude / wavelength


def westergaard_contact_half_width(amplitude: float, wavelength: float, plane_strain_modulus: float,
                                   mean_pressure: float) -> float:
    """Half-width a (m) of contact around each crest: sin^2(pi a / L) = P / p*."""
    return _core.westergaard_contact_half_width(amplitude, wavelength, plane_strain_modulus, mean_pressure)


def westergaard_element_pressure(x: np.ndarray, dx: float, amplitude: float, wavelength: float,
                                 plane_strain_modulus: float, mean_pressure: float) -> np.ndarray:
    """Exact Westergaard pressure averaged over each element [x - dx/2, x + dx/2] (Pa)."""
    return _core.westergaard_element_pressure(np.ascontiguousarray(x, dtype=np.float64), dx, amplitude,
                                              wavelength, plane_strain_modulus, mean_pressure)


def flat_punch_element_pressure(x: np.ndarray, dx: float, width: float, mean_pressure: float) -> np.ndarray:
    """Rigid flat punch of width L on a half-space, p = P L / (pi sqrt(x (L - x))), averaged per element (Pa)."""
    return _core.flat_punch_element_pressure(np.ascontiguousarray(x, dtype=np.float64), dx, width, mean_pressure)
