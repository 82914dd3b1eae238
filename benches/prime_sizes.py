"""FFT-friendly sizes inside the solver (issue 18): a segment whose N has a large prime factor
against its 5-smooth neighbour, in the same run.

    .venv/bin/python benches/prime_sizes.py [--repeats 3] [--tol 1e-10]

A 0.5 m segment at the CAPTIF interval (0.0375 mm) has N = 13,337 points, a prime; realfft
transforms such a size by Bluestein's algorithm, several times slower per point than a 5-smooth
size. The periodic kernel is therefore applied, for N with a prime factor above 31, as a linear
convolution on the 5-smooth size fast_len(2N - 1) (`kernel::circular_product_len` in the Rust
core). Prints, per N, its largest prime factor, iterations and best wall time of `contact_many` (4 moduli, one thread, warm-started
as in the bulk job) and the time per point relative to N = 13,500 (2^2 3^3 5^3). Run it on two
builds for before/after. A benchmark: it prints, it never fails on a number.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import roadtex

SIZES = (13_500, 13_337, 13_334, 13_333, 6_667, 1_000, 1_009)
MODULI = (1e6, 2.5e6, 5e6, 1e7)


def largest_prime_factor(n: int) -> int:
    largest, p = 1, 2
    while p * p <= n:
        while n % p == 0:
            largest, n = p, n // p
        p += 1
    return n if n > 1 else largest


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--tol", type=float, default=1e-10)
    parser.add_argument("--segments", type=int, default=4)
    args = parser.parse_args()
    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load average {os.getloadavg()[0]:.1f}, tol {args.tol:g}")
    print("# N, largest prime factor, iterations per solve, best seconds per segment (4 E), us per point, per point vs 13,500")
    per_point: dict[int, float] = {}
    for n in SIZES:
        dx = 0.5 / n
        profiles = [roadtex.synthetic.self_affine_profile(n, n * dx, hurst=0.8, rms_slope=0.2, seed=s) for s in range(args.segments)]
        segments = np.stack(profiles)
        segments *= 2e-3 / np.ptp(segments)  # a 2 mm texture, as on CAPTIF
        best = float("inf")
        for _ in range(args.repeats):
            started = time.perf_counter()
            batch = roadtex.contact_many(segments, dx, youngs_modulus=list(MODULI), mean_pressure=2e5, tol=args.tol, threads=1)
            best = min(best, time.perf_counter() - started)
        seconds = best / args.segments
        per_point[n] = seconds / n
        size = largest_prime_factor(n)
        iterations = float(np.mean(batch.iterations))
        ratio = per_point[n] / per_point[SIZES[0]]
        print(f"{n:6d}  {size:6d}  {iterations:5.1f}  {seconds:8.4f}  {per_point[n] * 1e6:6.2f}  {ratio:5.2f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
