"""FFT-friendly segment sizes: 5-smooth point counts (2^a 3^b 5^c) and the sampling intervals they give.

The contact solver applies its kernel by FFT on N points. A length with a large prime factor makes
the FFT fall back to a slow algorithm (Bluestein): the CAPTIF files' 0.5 m segments have N = 13,337
points, a prime, and one solve there costs about three times as much as on 10,000 points. Candidate
sampling intervals are therefore ``segment_length / N`` with N 5-smooth.
"""

from __future__ import annotations

import numpy as np

from roadtex._checks import positive, whole_number
from roadtex.errors import InvalidInputError


def is_five_smooth(n: int) -> bool:
    """True when the whole number ``n`` >= 1 has no prime factor above 5."""
    n = whole_number(n, "n", 1)
    for p in (2, 3, 5):
        while n % p == 0:
            n //= p
    return n == 1


def next_five_smooth(n: int) -> int:
    """The smallest 5-smooth whole number >= ``n`` (``n`` >= 1)."""
    n = whole_number(n, "n", 1)
    best = None
    power5 = 1
    while power5 < 2 * n:
        power35 = power5
        while power35 < 2 * n:
            # the smallest power of two taking power35 to n or beyond
            value = power35
            while value < n:
                value *= 2
            best = value if best is None else min(best, value)
            power35 *= 3
        power5 *= 5
    assert best is not None
    return best


def previous_five_smooth(n: int) -> int:
    """The largest 5-smooth whole number <= ``n`` (``n`` >= 1)."""
    n = whole_number(n, "n", 1)
    best = 1
    power5 = 1
    while power5 <= n:
        power35 = power5
        while power35 <= n:
            value = power35
            while value * 2 <= n:
                value *= 2
            best = max(best, value)
            power35 *= 3
        power5 *= 5
    return best


def five_smooth_ladder(finest_points: int, coarsest_points: int, *, ratio: float = 1.25) -> list[int]:
    """5-smooth point counts from at most ``finest_points`` down to at least ``coarsest_points``,
    each about ``ratio`` (> 1) times fewer than the one before, finest first."""
    finest = whole_number(finest_points, "finest_points", 8)
    coarsest = whole_number(coarsest_points, "coarsest_points", 8)
    step = positive(ratio, "ratio", "no unit")
    if step <= 1.0:
        raise InvalidInputError(f"ratio must be above 1, got {ratio!r}")
    ladder: list[int] = []
    target = float(finest)
    while target >= coarsest:
        n = previous_five_smooth(int(np.floor(target)))
        if n < coarsest:
            break
        if not ladder or n < ladder[-1]:
            ladder.append(n)
        target = n / step
    return ladder

