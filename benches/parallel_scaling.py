"""Parallel scaling of roadtex.contact_many: the same batch on 1 and on 2 (or more) threads.

Road-like segments: self-affine profiles (hurst 0.8, cutoff 0.25) of 4,096 points over 0.2 m with
rms slope 0.2, one seed per segment; rubber E = 2.5 MPa (nu = 0.5), mean pressure 0.2 MPa,
tol 1e-8. Each thread count is timed best of ``--repeats`` runs (wall clock); the script prints the
times, the speed-up over one thread, and checks that the pressures are bitwise identical whatever
the thread count (the batch layer promises it).

Run:  .venv/bin/python benches/parallel_scaling.py [--segments 1000] [--points 4096] [--threads 1 2]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

import roadtex
from roadtex.profiles.synthetic import self_affine_profile

LENGTH = 0.2  # m
RMS_SLOPE = 0.2
YOUNGS_MODULUS = 2.5e6  # Pa
MEAN_PRESSURE = 2e5  # Pa
TOL = 1e-8


def make_segments(count: int, points: int) -> np.ndarray:
    return np.stack([self_affine_profile(points, LENGTH, rms_slope=RMS_SLOPE, seed=seed) for seed in range(count)])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--segments", type=int, default=1000)
    parser.add_argument("--points", type=int, default=4096)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()

    segments = make_segments(args.segments, args.points)
    dx = LENGTH / args.points
    print(f"roadtex {roadtex.__version__}: {args.segments} segments x {args.points} points, "
          f"dx = {dx:.3e} m, E = {YOUNGS_MODULUS:.3g} Pa, P = {MEAN_PRESSURE:.3g} Pa, tol = {TOL:g}, "
          f"best of {args.repeats}; {os.cpu_count()} CPUs")

    best: dict[int, float] = {}
    results: dict[int, roadtex.ContactBatch] = {}
    for threads in args.threads:
        times, cores = [], []
        for _ in range(args.repeats):
            start, cpu_start = time.perf_counter(), time.process_time()
            batch = roadtex.contact_many(segments, dx, YOUNGS_MODULUS, MEAN_PRESSURE, tol=TOL, threads=threads)
            times.append(time.perf_counter() - start)
            cores.append((time.process_time() - cpu_start) / times[-1])
        best[threads] = min(times)
        results[threads] = batch
        print(f"threads={threads}: best {best[threads]:.3f} s "
              f"({1e3 * best[threads] / args.segments:.3f} ms per segment); runs "
              + ", ".join(f"{t:.3f}" for t in times)
              + "; cores used (CPU/wall) " + ", ".join(f"{c:.2f}" for c in cores))

    first = args.threads[0]
    ref = results[first]
    iters = ref.iterations[:, 0]
    print(f"iterations per segment: min {iters.min()}, median {int(np.median(iters))}, max {iters.max()}; "
          f"all converged: {bool(ref.converged.all())}; "
          f"contact fraction median {np.median((ref.pressure[:, 0] > 0).mean(axis=1)):.3f}")

    identical = True
    for threads in args.threads[1:]:
        print(f"speed-up threads={threads} vs threads={first}: {best[first] / best[threads]:.2f}x")
        same = (np.array_equal(results[threads].pressure, ref.pressure)
                and np.array_equal(results[threads].iterations, ref.iterations))
        print(f"bitwise identical pressure and iterations, threads={threads} vs threads={first}: {same}")
        identical &= same
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
