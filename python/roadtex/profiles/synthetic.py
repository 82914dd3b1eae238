"""Reproducible synthetic profiles for tests, benchmarks and the demo."""

from __future__ import annotations

import numpy as np

from roadtex import _core


def self_affine_profile(n: int, length: float, *, hurst: float = 0.8, rms_slope: float = 0.1,
                        cutoff_fraction: float = 0.25, seed: int = 0) -> np.ndarray:
    """A periodic self-affine (fractal) profile of ``n`` points over ``length`` (m).

    Fourier amplitudes |h_k| ~ k^-(hurst + 1/2) for 1 <= k < n * cutoff_fraction with random
    phases from ``seed``; scaled so the finite-difference slope has rms ``rms_slope``; mean zero.
    Returns heights in metres.
    """
    return _core.self_affine_profile(int(n), float(length), float(hurst), float(rms_slope),
                                     float(cutoff_fraction), int(seed))
