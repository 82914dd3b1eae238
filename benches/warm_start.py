"""Coarse starts for model-grid solves (issue 39): each solve on a grid k times finer than the data
started from the data grid's answer (``contact_many(..., coarse_start=k)``) against the job's
solve of today (``warm_start=True`` alone: the first modulus cold, the others from their neighbour).

    .venv/bin/python benches/warm_start.py               # 0.5 and 1 mm, k = 4, 6, 8, 12, tol 1e-6 and 1e-4
    .venv/bin/python benches/warm_start.py --segments 4 --repeat 1 --k 4 8

For synthetic dense and porous asphalt (``roadtex.synthetic_pavement``, 0.5 m segments, linear
interpolant as the job's default), E = 1, 2, 5, 10 MPa, P = 0.2 MPa, one thread, per (dx, kind, k,
tol) it prints the fine-grid iterations per solve and the CPU time per segment (its four moduli)
of: ``k=1`` the data grid's solve alone (what the model grid is compared with), ``cold`` today's
model-grid solve, ``warm`` with the coarse start (the data-grid solve included in its time), and
``every`` the coarse start for every modulus without the moduli chain; ``floor`` is one numpy
real FFT pair of N k points times the cold solve's iterations (a lower bound of an FFT solve's
time, see benches/fft_floor.rs for the Rust core's own). ``diff/tol`` is the worst difference
between the warm and cold envelopes relative to the profile's peak-to-valley height (the solver's
residual's scale) over ``tol``; ``dB`` the worst difference of their enveloped band levels. Times
are the best of --repeat runs. A benchmark: it prints, it never fails on a number.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import roadtex
from roadtex.models.grid import refine_periodic

MODULI = np.array([1e6, 2e6, 5e6, 10e6])
PRESSURE = 2e5
SEGMENT = 0.5


def timed(repeat: int, call):  # type: ignore[no-untyped-def]
    """(best CPU time in s, last result) of ``repeat`` calls (one thread: process CPU time)."""
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.process_time()
        result = call()
        best = min(best, time.process_time() - start)
    return best, result


def fft_pair_time(n: int) -> float:
    """One numpy real FFT forward and inverse pair of n points (s), best of batches."""
    x = np.random.default_rng(0).standard_normal(n)
    loops = max(1, 200_000 // n)
    best = float("inf")
    for _ in range(5):
        start = time.process_time()
        for _ in range(loops):
            np.fft.irfft(np.fft.rfft(x), n)
        best = min(best, (time.process_time() - start) / loops)
    return best


def segments(kind: str, dx: float, count: int) -> np.ndarray:
    profile = roadtex.synthetic_pavement(kind, count * SEGMENT, dx, seed=7)
    return profile.segments(SEGMENT).heights


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--segments", type=int, default=8, help="0.5 m segments per pavement (default 8)")
    parser.add_argument("--repeat", type=int, default=3, help="timings per case, the best kept (default 3)")
    parser.add_argument("--k", type=int, nargs="+", default=[4, 6, 8, 12])
    parser.add_argument("--tol", type=float, nargs="+", default=[1e-6, 1e-4])
    parser.add_argument("--dx", type=float, nargs="+", default=[0.5e-3, 1e-3])
    args = parser.parse_args()
    print(f"roadtex {roadtex.__version__}; {args.segments} segments of {SEGMENT} m per pavement, E = 1, 2, 5, 10 MPa, "
          f"P = 0.2 MPa, one thread, linear interpolant")
    print(f"{'dx mm':>5} {'kind':>8} {'k':>3} {'tol':>5} | {'iterations per solve':^27} | "
          f"{'ms per segment (4 moduli)':^42} | {'warm/cold':>9} {'diff/tol':>8} {'dB':>7}")
    print(f"{'':>5} {'':>8} {'':>3} {'':>5} | {'k=1':>6} {'cold':>6} {'warm':>6} {'every':>6} | "
          f"{'k=1':>6} {'cold':>7} {'warm':>7} {'every':>7} {'floor':>7} | {'time':>9} {'':>8} {'':>7}")
    for dx in args.dx:
        for kind in ("dense_asphalt", "porous_asphalt"):
            heights = segments(kind, dx, args.segments)
            count = heights.shape[0]
            for tol in args.tol:
                common = {"tol": tol, "threads": 1, "raise_on_nonconvergence": False}
                t1, data = timed(args.repeat, lambda: roadtex.contact_many(
                    heights, dx, MODULI, PRESSURE, warm_start=True, **common))
                for k in args.k:
                    model = refine_periodic(heights, k, "linear")
                    model_dx = dx / k
                    tc, cold = timed(args.repeat, lambda: roadtex.contact_many(
                        model, model_dx, MODULI, PRESSURE, warm_start=True, **common))
                    tw, warm = timed(args.repeat, lambda: roadtex.contact_many(
                        model, model_dx, MODULI, PRESSURE, warm_start=True, coarse_start=k, **common))
                    te, every = timed(args.repeat, lambda: roadtex.contact_many(
                        model, model_dx, MODULI, PRESSURE, coarse_start=k, **common))
                    assert cold.converged.all() and warm.converged.all() and every.converged.all()
                    floor = fft_pair_time(model.shape[1]) * cold.iterations.mean() * MODULI.size
                    height = np.ptp(model, axis=1)[:, None, None]
                    diff = float((np.abs(warm.envelope - cold.envelope) / height).max()) / tol
                    levels = [roadtex.band_levels(b.envelope.reshape(-1, model.shape[1]), model_dx, periodic=True).levels
                              for b in (cold, warm)]
                    db = float(np.nanmax(np.abs(levels[1] - levels[0])))
                    ms = [1e3 * t / count for t in (t1, tc, tw, te)]
                    print(f"{dx * 1e3:>5.2g} {kind[:8]:>8} {k:>3} {tol:>5.0e} | "
                          f"{data.iterations.mean():>6.1f} {cold.iterations.mean():>6.1f} {warm.iterations.mean():>6.1f} "
                          f"{every.iterations.mean():>6.1f} | {ms[0]:>6.2f} {ms[1]:>7.2f} {ms[2]:>7.2f} {ms[3]:>7.2f} "
                          f"{1e3 * floor / count:>7.2f} | {tw / tc:>9.2f} {diff:>8.3f} {db:>7.4f}", flush=True)


if __name__ == "__main__":
    main()
