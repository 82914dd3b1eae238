"""Speed against error: roadtex next to the peer library tamaas, in one run.

Run from the project root:

    .venv/bin/python benches/speed_vs_error.py            # default, a few minutes on 2 cores
    .venv/bin/python benches/speed_vs_error.py --quick    # small N only: a smoke run
    .venv/bin/python benches/speed_vs_error.py --large    # adds the self-affine N = 2^18 and 2^20 (long)
    .venv/bin/python benches/speed_vs_error.py --json rows.json

tamaas is optional (``.venv/bin/python -m pip install -r scripts/requirements-bench.txt``); without
it only the roadtex rows are printed. This is a benchmark, not a test: it prints tables and never
fails on a number.

Cases
  1. Westergaard wavy surface z = A cos(2 pi x / L) at P = 0.3 p* (p* = pi E* A / L), N = 2^10..2^16,
     tol 1e-6, 1e-8, 1e-10. Errors against the exact pressure averaged per element: the L1 relative
     error sum|p - p_exact| / sum p_exact and the contact half-width error in dx.
  2. Self-affine profile (Hurst 0.8, rms slope 0.1, cutoff N/4, L = 1, E* = 1, P = 0.0105, about
     21 % contact), tol 1e-8, N = 1,000 (the bulk job's segment size), 2^12, 2^14, 2^16 (2^18 with
     --large). References: roadtex
     method="direct" (dense active-set solve, same kernel) for N <= 4096, and, for every N, roadtex
     kernel="spectral" against tamaas, which solves the same discrete problem (the kernel
     2 / (E* |k|) on collocation points).
  3. Iteration growth (roadtex only, the issue's N^0.3 target): the self-affine case at tol 1e-8
     for N = 2^10, 2^12, ..., 2^18 (2^20 with --large; up to 2^14 with --quick) and seeds 0, 1, 2:
     iterations and time per N, and the exponent b of a least-squares fit iterations ~ N^b over
     the whole range and over 2^10..2^16.
  4. tamaas 2.9.0 on the same problems: Model(model_type.basic_1d, [L], [N]) with E and nu set,
     PolonskyKeerRey(model, heights, tol, pressure, pressure).solve(P), cold start (a new model
     and solver for every run), one thread. The heights go to tamaas as they are: tamaas's
     "surface" is the rigid surface with contact at its peaks, as roadtex's road profile; a check
     on a small case confirms it before anything is timed.

Columns
  time     wall time of one cold call (set-up + solve), the best of up to --max-repeats runs
           (fewer for slow runs); tamaas includes building its Model and solver.
  iters    roadtex: CG iterations (active-set sweeps for "direct"); tamaas: Polonsky-Keer
           iterations performed, read from its solver log (its last logged iteration index + 1
           when it converged), since tamaas does not return the count.
  resid    roadtex's stopping measure, the worst open gap on the contact set or penetration off it
           over the profile's peak-to-valley height. For tamaas it is computed here from its
           pressures with the spectral kernel. tamaas stops on its own error measure (an
           energy-like complementarity error), so the same tol does not mean the same accuracy.
  sp<->tm  max|p_roadtex_spectral - p_tamaas| / P, and L1 sp-tm = sum|difference| / sum p: both solve
           the same discrete problem, so they differ only by what each leaves unconverged. A gap
           tolerance relative to peak-to-valley allows pressure errors that grow like N (a gap
           error d on one point moves its pressure by about E* d / dx), so the max difference
           grows with N at fixed tol and shrinks about 100x when tol does.
  tm/rt    tamaas time over roadtex time: against roadtex element (the default kernel) and
           against roadtex spectral (the same discrete problem as tamaas).

Both libraries run on one thread (OMP_NUM_THREADS=1 and RAYON_NUM_THREADS=1 are set before
either is imported). Timings on a loaded machine are noisy: the header prints the load average.
"""

from __future__ import annotations

import os

# One thread for both libraries, set before either is imported.
os.environ["OMP_NUM_THREADS"] = "1"
os.environ["RAYON_NUM_THREADS"] = "1"

import argparse
import json
import math
import platform
import re
import sys
import tempfile
import time
from contextlib import contextmanager
from typing import Callable, Iterator

import numpy as np

import roadtex
from roadtex import reference
from roadtex.profiles.synthetic import self_affine_profile

try:
    import tamaas as tm
    TAMAAS_IMPORT_ERROR: str | None = None
except Exception as exc:  # ImportError, or tamaas's own failure to load its extension
    tm = None
    TAMAAS_IMPORT_ERROR = f"{type(exc).__name__}: {exc}"

# Case 1: the Westergaard wavy surface, in SI units of a tyre tread on a road.
WG_WAVELENGTH = 0.01  # m
WG_AMPLITUDE = 1e-4  # m
WG_YOUNGS = 2.5e6  # Pa
WG_POISSON = 0.5
WG_LOAD_FRACTION = 0.3  # P / p*
WG_TOLS = (1e-6, 1e-8, 1e-10)

# Case 2: the self-affine profile, E* = 1 units (E = 0.75, nu = 0.5).
SA_LENGTH = 1.0
SA_HURST = 0.8
SA_RMS_SLOPE = 0.1
SA_CUTOFF = 0.25
SA_YOUNGS = 0.75
SA_POISSON = 0.5
SA_PRESSURE = 0.0105
SA_TOL = 1e-8
DIRECT_MAX_N = 4096

MAX_ITERATIONS = 1_000_000  # both solvers: effectively no cap, convergence is reported instead

ROWS: list[dict] = []


# --------------------------------------------------------------------------- timing


def best_time(run: Callable[[], object], max_repeats: int) -> tuple[float, object, int]:
    """Runs ``run`` once, then again while cheap; returns (best seconds, last result, runs)."""
    t0 = time.perf_counter()
    result = run()
    best = time.perf_counter() - t0
    runs = 1
    # Cheap runs are repeated up to max_repeats; runs over 1 s at most twice; over 5 s once.
    wanted = max_repeats if best < 1.0 else (min(2, max_repeats) if best < 5.0 else 1)
    while runs < wanted:
        t0 = time.perf_counter()
        result = run()
        best = min(best, time.perf_counter() - t0)
        runs += 1
    return best, result, runs


# --------------------------------------------------------------------------- solvers


def solve_roadtex(heights: np.ndarray, dx: float, youngs: float, poisson: float, pressure: float, tol: float,
                  kernel: str = "element", method: str = "cg") -> roadtex.ContactResult:
    return roadtex.contact(heights, dx, youngs, pressure, poisson=poisson, kernel=kernel, method=method, tol=tol,
                           max_iterations=MAX_ITERATIONS, raise_on_nonconvergence=False)


@contextmanager
def captured_stderr_fd() -> Iterator[list[str]]:
    """Captures what C++ code writes to file descriptor 2 (tamaas logs there); yields a list that
    receives the captured text on exit."""
    out: list[str] = []
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield out
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            out.append(tmp.read().decode("utf-8", "replace"))


_LOG_LINE = re.compile(r"^\s*(\d+)\s+[-+0-9.eEinfa]+\s+[-+0-9.eEinfa]+\s*$")


class TamaasResult:
    def __init__(self, pressure: np.ndarray, iterations: int | None, error: float, converged: bool, log: str):
        self.pressure = pressure
        self.iterations = iterations
        self.error = error
        self.converged = converged
        self.log = log


def solve_tamaas(heights: np.ndarray, length: float, youngs: float, poisson: float, pressure: float,
                 tol: float, sign: float = 1.0) -> TamaasResult:
    """One cold tamaas solve: a new 1-D periodic model and Polonsky-Keer-Rey solver, load control."""
    n = heights.size
    surface = np.ascontiguousarray(sign * heights, dtype=np.float64).copy()  # tamaas keeps a view
    with captured_stderr_fd() as log:
        model = tm.Model(tm.model_type.basic_1d, [length], [n])
        model.E = youngs
        model.nu = poisson
        solver = tm.PolonskyKeerRey(model, surface, tol, tm.PolonskyKeerRey.pressure,
                                    tm.PolonskyKeerRey.pressure)
        solver.max_iter = MAX_ITERATIONS
        solver.dump_freq = MAX_ITERATIONS + 1  # log only the first and the last iteration
        error = float(solver.solve(pressure))
        traction = np.array(model.traction, dtype=np.float64, copy=True).reshape(-1)
    text = log[0] if log else ""
    converged = error <= tol
    last = None
    for line in text.splitlines():
        m = _LOG_LINE.match(line)
        if m:
            last = int(m.group(1))
    # tamaas logs the index of its last iteration (from 0); stopped by max_iter it logs one more.
    iterations = None if last is None else (last + 1 if converged else last)
    return TamaasResult(traction, iterations, error, converged, text)


def run_tamaas(heights: np.ndarray, length: float, youngs: float, poisson: float, pressure: float, tol: float,
               sign: float, max_repeats: int) -> tuple[float, TamaasResult, int]:
    return best_time(lambda: solve_tamaas(heights, length, youngs, poisson, pressure, tol, sign), max_repeats)


# --------------------------------------------------------------------------- error measures


def spectral_displacement(pressure: np.ndarray, length: float, e_star: float) -> np.ndarray:
    """Surface displacement of the half-space under periodic pressure, kernel 2 / (E* |k|), mean 0."""
    n = pressure.size
    k = 2.0 * np.pi * np.fft.rfftfreq(n, d=length / n)
    mult = np.zeros_like(k)
    mult[1:] = 2.0 / (e_star * k[1:])
    return np.fft.irfft(np.fft.rfft(pressure) * mult, n)


def gap_residual(pressure: np.ndarray, heights: np.ndarray, length: float, e_star: float) -> float:
    """roadtex's stopping measure for a pressure field on the spectral kernel: the worst |gap| on the
    contact set or penetration off it, over peak-to-valley; the rigid approach is the mid-range of
    heights - displacement on the contact set."""
    u = spectral_displacement(pressure, length, e_star)
    contact = pressure > 0.0
    if not contact.any():
        return math.inf
    d = (heights - u)[contact]
    approach = 0.5 * (d.max() + d.min())
    gap = u + approach - heights
    violation = np.where(contact, np.abs(gap), np.maximum(-gap, 0.0))
    return float(violation.max() / np.ptp(heights))


def max_diff_over_p(a: np.ndarray, b: np.ndarray, mean_pressure: float) -> float:
    return float(np.max(np.abs(a - b)) / mean_pressure)


def contact_fraction(pressure: np.ndarray) -> float:
    return float(np.count_nonzero(pressure > 0.0) / pressure.size)


def westergaard_errors(pressure: np.ndarray, exact: np.ndarray, dx: float, half_width: float) -> tuple[float, float]:
    """(L1 relative pressure error, contact half-width error in dx) for one crest at x = 0."""
    l1 = float(np.abs(pressure - exact).sum() / exact.sum())
    numerical_half_width = 0.5 * np.count_nonzero(pressure > 0.0) * dx
    return l1, float((numerical_half_width - half_width) / dx)


# --------------------------------------------------------------------------- output


def fmt(value: object, spec: str, width: int) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        text = "-"
    elif isinstance(value, str):
        text = value
    else:
        text = format(value, spec)
    return text.rjust(width)


class Table:
    def __init__(self, columns: list[tuple[str, str, int]]):
        self.columns = columns  # (header, format spec, width)

    def header(self) -> None:
        line = "  ".join(h.rjust(w) for h, _, w in self.columns)
        print(line)
        print("-" * len(line), flush=True)

    def row(self, values: list[object]) -> None:
        print("  ".join(fmt(v, s, w) for v, (_, s, w) in zip(values, self.columns)), flush=True)


def iters_text(iterations: int | None, converged: bool) -> str:
    text = "n/a" if iterations is None else str(iterations)
    return text if converged else text + "!"


def ratio_text(numerator: float | None, denominator: float | None) -> str | None:
    if numerator is None or not denominator:
        return None
    return f"{numerator / denominator:.1f}x"


# --------------------------------------------------------------------------- sign / problem check


def check_tamaas_problem(seed: int) -> float | None:
    """Solves a small self-affine case with roadtex (spectral kernel) and tamaas, with the heights as
    given and negated; returns the sign under which both agree (same contact set, pressures equal
    to about tol), or None if neither does. Prints what it found."""
    n = 1024
    heights = self_affine_profile(n, SA_LENGTH, hurst=SA_HURST, rms_slope=SA_RMS_SLOPE, cutoff_fraction=SA_CUTOFF,
                                  seed=seed)
    dx = SA_LENGTH / n
    e_star = SA_YOUNGS / (1.0 - SA_POISSON**2)
    rt = solve_roadtex(heights, dx, SA_YOUNGS, SA_POISSON, SA_PRESSURE, 1e-10, kernel="spectral")
    rt_own = gap_residual(rt.pressure, heights, SA_LENGTH, e_star)
    print(f"Problem check (self-affine N={n}, tol 1e-10): roadtex spectral contact {rt.contact_fraction:.4f}, "
          f"residual {rt.residual:.2e} (recomputed here: {rt_own:.2e})")
    chosen = None
    for sign in (1.0, -1.0):
        res = solve_tamaas(heights, SA_LENGTH, SA_YOUNGS, SA_POISSON, SA_PRESSURE, 1e-10, sign)
        same_set = bool(np.array_equal(res.pressure > 0.0, rt.pressure > 0.0))
        diff = max_diff_over_p(res.pressure, rt.pressure, SA_PRESSURE)
        mean_ok = abs(res.pressure.mean() / SA_PRESSURE - 1.0) < 1e-8
        label = "heights as given" if sign > 0 else "heights negated"
        print(f"  tamaas, {label}: contact {contact_fraction(res.pressure):.4f}, same contact set: {same_set}, "
              f"max|dp|/P = {diff:.2e}, mean p = P: {mean_ok}, iterations {res.iterations}")
        if chosen is None and same_set and diff < 1e-4 and mean_ok:
            chosen = sign
    if chosen is None:
        print("  WARNING: tamaas does not reproduce roadtex's spectral solution either way; its rows are unverified")
    else:
        print(f"  -> tamaas gets the heights {'as given' if chosen > 0 else 'negated'} "
              f"(its surface is the rigid surface, contact at its peaks, as roadtex's road)")
    print(flush=True)
    return chosen


# --------------------------------------------------------------------------- case 1


def case_westergaard(sizes: list[int], max_repeats: int, tamaas_sign: float | None) -> None:
    e_star = WG_YOUNGS / (1.0 - WG_POISSON**2)
    p_star = reference.westergaard_full_contact_pressure(WG_AMPLITUDE, WG_WAVELENGTH, e_star)
    pressure = WG_LOAD_FRACTION * p_star
    half_width = reference.westergaard_contact_half_width(WG_AMPLITUDE, WG_WAVELENGTH, e_star, pressure)
    print(f"Case 1: Westergaard z = A cos(2 pi x / L), L = {WG_WAVELENGTH} m, A = {WG_AMPLITUDE} m, "
          f"E = {WG_YOUNGS:g} Pa, nu = {WG_POISSON} (E* = {e_star:.6g} Pa), P = {WG_LOAD_FRACTION} p* = {pressure:.6g} Pa, "
          f"exact contact fraction {2 * half_width / WG_WAVELENGTH:.4f}")
    print("  L1 err = sum|p - p_exact| / sum p_exact against the exact pressure averaged per element; "
          "hw err = contact half-width error in dx; '!' = not converged")
    table = Table([("N", "d", 6), ("tol", ".0e", 6), ("solver", "s", 16), ("time[s]", ".4f", 9), ("iters", "s", 7),
                   ("L1 err", ".2e", 9), ("hw err", "+.3f", 7), ("resid", ".1e", 8), ("tm/rt_el", "s", 8),
                   ("tm/rt_sp", "s", 8)])
    table.header()
    for n in sizes:
        heights, dx = reference.westergaard_profile(n, WG_WAVELENGTH, WG_AMPLITUDE)
        x = np.arange(n) * dx
        exact = reference.westergaard_element_pressure(x, dx, WG_AMPLITUDE, WG_WAVELENGTH, e_star, pressure)
        for tol in WG_TOLS:
            times: dict[str, float] = {}
            for kernel in ("element", "spectral"):
                t, r, runs = best_time(lambda: solve_roadtex(heights, dx, WG_YOUNGS, WG_POISSON, pressure, tol, kernel),
                                       max_repeats)
                times[kernel] = t
                l1, hw = westergaard_errors(r.pressure, exact, dx, half_width)
                table.row([n, tol, f"roadtex {kernel}", t, iters_text(r.iterations, r.converged), l1, hw, r.residual,
                           None, None])
                ROWS.append(dict(case="westergaard", n=n, tol=tol, solver=f"roadtex-{kernel}", time_s=t, runs=runs,
                                 iterations=r.iterations, converged=r.converged, l1_error=l1, half_width_error_dx=hw,
                                 residual=r.residual, contact_fraction=r.contact_fraction))
            if tamaas_sign is not None:
                t, res, runs = run_tamaas(heights, WG_WAVELENGTH, WG_YOUNGS, WG_POISSON, pressure, tol, tamaas_sign,
                                          max_repeats)
                l1, hw = westergaard_errors(res.pressure, exact, dx, half_width)
                resid = gap_residual(res.pressure, heights, WG_WAVELENGTH, e_star)
                table.row([n, tol, "tamaas PKR", t, iters_text(res.iterations, res.converged), l1, hw, resid,
                           ratio_text(t, times["element"]), ratio_text(t, times["spectral"])])
                ROWS.append(dict(case="westergaard", n=n, tol=tol, solver="tamaas", time_s=t, runs=runs,
                                 iterations=res.iterations, converged=res.converged, tamaas_error=res.error,
                                 l1_error=l1, half_width_error_dx=hw, residual=resid,
                                 contact_fraction=contact_fraction(res.pressure),
                                 ratio_vs_roadtex_element=t / times["element"],
                                 ratio_vs_roadtex_spectral=t / times["spectral"]))
    print(flush=True)


# --------------------------------------------------------------------------- case 2


def case_self_affine(sizes: list[int], max_repeats: int, tamaas_sign: float | None, tamaas_max_n: int,
                     seed: int) -> None:
    e_star = SA_YOUNGS / (1.0 - SA_POISSON**2)
    print(f"Case 2: self-affine profile, Hurst {SA_HURST}, rms slope {SA_RMS_SLOPE}, cutoff N*{SA_CUTOFF}, seed {seed}, "
          f"L = {SA_LENGTH}, E* = {e_star:g} (E = {SA_YOUNGS}, nu = {SA_POISSON}), P = {SA_PRESSURE}, tol {SA_TOL:g}")
    print(f"  vs direct = max|p - p_direct|/P against roadtex method='direct' with the same kernel (N <= {DIRECT_MAX_N}; "
          "tamaas against direct spectral); sp<->tm = max|p_roadtex_spectral - p_tamaas|/P, "
          "L1 sp-tm = sum|p_roadtex_spectral - p_tamaas| / sum p")
    table = Table([("N", "d", 6), ("solver", "s", 17), ("time[s]", ".3f", 8), ("iters", "s", 7),
                   ("contact", ".4f", 7), ("resid", ".1e", 8), ("vs direct", ".1e", 9), ("sp<->tm", ".1e", 8),
                   ("L1 sp-tm", ".1e", 8), ("tm/rt_el", "s", 8), ("tm/rt_sp", "s", 8)])
    table.header()
    for n in sizes:
        heights = self_affine_profile(n, SA_LENGTH, hurst=SA_HURST, rms_slope=SA_RMS_SLOPE, cutoff_fraction=SA_CUTOFF,
                                      seed=seed)
        dx = SA_LENGTH / n
        results = {}
        times = {}
        runs_of = {}
        for kernel in ("element", "spectral"):
            t, r, runs = best_time(lambda: solve_roadtex(heights, dx, SA_YOUNGS, SA_POISSON, SA_PRESSURE, SA_TOL, kernel),
                                   max_repeats)
            results[kernel], times[kernel], runs_of[kernel] = r, t, runs
        direct = {}
        direct_times = {}
        if n <= DIRECT_MAX_N:
            for kernel in ("element", "spectral"):
                t0 = time.perf_counter()
                direct[kernel] = solve_roadtex(heights, dx, SA_YOUNGS, SA_POISSON, SA_PRESSURE, 1e-12, kernel, "direct")
                direct_times[kernel] = time.perf_counter() - t0
        tam = None
        if tamaas_sign is not None and n <= tamaas_max_n:
            t, res, runs = run_tamaas(heights, SA_LENGTH, SA_YOUNGS, SA_POISSON, SA_PRESSURE, SA_TOL, tamaas_sign,
                                      max_repeats)
            tam = (t, res, runs)
        sp_tm = None if tam is None else max_diff_over_p(results["spectral"].pressure, tam[1].pressure, SA_PRESSURE)
        sp_tm_l1 = (None if tam is None else
                    float(np.abs(results["spectral"].pressure - tam[1].pressure).sum() / results["spectral"].pressure.sum()))

        for kernel in ("element", "spectral"):
            r = results[kernel]
            vs_direct = max_diff_over_p(r.pressure, direct[kernel].pressure, SA_PRESSURE) if kernel in direct else None
            table.row([n, f"roadtex {kernel}", times[kernel], iters_text(r.iterations, r.converged),
                       r.contact_fraction, r.residual, vs_direct, sp_tm if kernel == "spectral" else None,
                       sp_tm_l1 if kernel == "spectral" else None, None, None])
            ROWS.append(dict(case="self_affine", n=n, tol=SA_TOL, seed=seed, solver=f"roadtex-{kernel}",
                             time_s=times[kernel], runs=runs_of[kernel], iterations=r.iterations, converged=r.converged,
                             contact_fraction=r.contact_fraction, residual=r.residual,
                             max_diff_vs_direct_over_p=vs_direct,
                             max_diff_vs_tamaas_over_p=sp_tm if kernel == "spectral" else None,
                             l1_diff_vs_tamaas=sp_tm_l1 if kernel == "spectral" else None))
        for kernel, d in direct.items():
            table.row([n, f"roadtex direct {kernel[:2]}", direct_times[kernel], iters_text(d.iterations, d.converged),
                       d.contact_fraction, d.residual, None, None, None, None, None])
            ROWS.append(dict(case="self_affine", n=n, tol=1e-12, seed=seed, solver=f"roadtex-direct-{kernel}",
                             time_s=direct_times[kernel], runs=1, iterations=d.iterations, converged=d.converged,
                             contact_fraction=d.contact_fraction, residual=d.residual))
        if tam is not None:
            t, res, runs = tam
            resid = gap_residual(res.pressure, heights, SA_LENGTH, e_star)
            vs_direct = (max_diff_over_p(res.pressure, direct["spectral"].pressure, SA_PRESSURE)
                         if "spectral" in direct else None)
            table.row([n, "tamaas PKR", t, iters_text(res.iterations, res.converged), contact_fraction(res.pressure),
                       resid, vs_direct, sp_tm, sp_tm_l1, ratio_text(t, times["element"]),
                       ratio_text(t, times["spectral"])])
            ROWS.append(dict(case="self_affine", n=n, tol=SA_TOL, seed=seed, solver="tamaas", time_s=t, runs=runs,
                             iterations=res.iterations, converged=res.converged, tamaas_error=res.error,
                             contact_fraction=contact_fraction(res.pressure), residual=resid,
                             max_diff_vs_direct_over_p=vs_direct, max_diff_vs_tamaas_over_p=sp_tm,
                             l1_diff_vs_tamaas=sp_tm_l1,
                             ratio_vs_roadtex_element=t / times["element"],
                             ratio_vs_roadtex_spectral=t / times["spectral"]))
        elif tamaas_sign is not None:
            print(f"{n:6d}  tamaas PKR skipped: N > --tamaas-max-n {tamaas_max_n}", flush=True)
    print(flush=True)


def case_iteration_growth(sizes: list[int], seeds: tuple[int, ...]) -> None:
    print(f"Case 3: iteration growth, the self-affine case of case 2 (tol {SA_TOL:g}), seeds {list(seeds)}, "
          "roadtex element kernel; b = exponent of a least-squares fit iterations ~ N^b of the mean iterations")
    table = Table([("N", "d", 8), ("iterations by seed", "s", 20), ("mean", ".1f", 6), ("time[s]", ".3f", 8)])
    table.header()
    means = []
    for n in sizes:
        counts = []
        times = []
        for seed in seeds:
            heights = self_affine_profile(n, SA_LENGTH, hurst=SA_HURST, rms_slope=SA_RMS_SLOPE, cutoff_fraction=SA_CUTOFF,
                                          seed=seed)
            t0 = time.perf_counter()
            r = solve_roadtex(heights, SA_LENGTH / n, SA_YOUNGS, SA_POISSON, SA_PRESSURE, SA_TOL)
            times.append(time.perf_counter() - t0)
            counts.append(r.iterations if r.converged else -1)
        means.append(float(np.mean(counts)))
        table.row([n, " ".join(str(c) for c in counts), means[-1], min(times)])
        ROWS.append(dict(case="iteration_growth", n=n, tol=SA_TOL, seeds=list(seeds), iterations=counts,
                         mean_iterations=means[-1], best_time_s=min(times)))
    sizes_array = np.array(sizes, dtype=float)
    means_array = np.array(means)
    ranges = [(sizes[0], sizes[-1])]
    if sizes[-1] > 1 << 16 and 1 << 16 in sizes:
        ranges.append((sizes[0], 1 << 16))
    for lo, hi in ranges:
        pick = (sizes_array >= lo) & (sizes_array <= hi)
        exponent = np.polyfit(np.log(sizes_array[pick]), np.log(means_array[pick]), 1)[0]
        print(f"  iterations ~ N^{exponent:.3f} over N = {lo}..{hi} (target: exponent <= 0.3)")
        ROWS.append(dict(case="iteration_growth_fit", n_min=lo, n_max=hi, exponent=float(exponent)))
    print(flush=True)


# --------------------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="small N only (a smoke run, well under a minute)")
    parser.add_argument("--large", action="store_true", help="add the self-affine N = 2^18 to case 2 and 2^20 to case 3 (minutes)")
    parser.add_argument("--json", metavar="PATH", help="also write every row to PATH as JSON")
    parser.add_argument("--seed", type=int, default=1, help="self-affine profile seed (default 1, as benches/contact.rs)")
    parser.add_argument("--max-repeats", type=int, default=3, help="best of at most this many runs (default 3)")
    parser.add_argument("--tamaas-max-n", type=int, default=1 << 16,
                        help="largest self-affine N given to tamaas (default 65536; 2^18 takes tamaas a very long time)")
    parser.add_argument("--no-tamaas", action="store_true", help="roadtex rows only")
    args = parser.parse_args(argv)
    if args.max_repeats < 1:
        parser.error("--max-repeats must be at least 1")

    if args.quick:
        wg_sizes = [1 << 10, 1 << 12]
        sa_sizes = [1000, 1 << 10, 1 << 12]
        growth_sizes = [1 << k for k in range(10, 15, 2)]
    else:
        wg_sizes = [1 << k for k in range(10, 17)]
        sa_sizes = [1000, 1 << 12, 1 << 14, 1 << 16]
        growth_sizes = [1 << k for k in range(10, 19, 2)]
    if args.large:
        sa_sizes.append(1 << 18)
        growth_sizes.append(1 << 20)

    started = time.perf_counter()
    print(f"roadtex {roadtex.__version__} vs tamaas: speed against error")
    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}, {os.cpu_count()} cores, "
          f"load average at start {os.getloadavg()[0]:.2f}; OMP_NUM_THREADS=1, RAYON_NUM_THREADS=1")
    use_tamaas = tm is not None and not args.no_tamaas
    if tm is None:
        print(f"tamaas: MISSING ({TAMAAS_IMPORT_ERROR}); roadtex rows only. "
              "Install with: .venv/bin/python -m pip install -r scripts/requirements-bench.txt")
    elif args.no_tamaas:
        print("tamaas: left out (--no-tamaas)")
    else:
        info = tm.TamaasInfo
        print(f"tamaas {info.version} (backend {info.backend}, mpi {info.has_mpi}): Model(model_type.basic_1d), "
              "PolonskyKeerRey(primal=pressure, constraint=pressure).solve(P), cold start")
    print(flush=True)

    tamaas_sign = check_tamaas_problem(args.seed) if use_tamaas else None
    case_westergaard(wg_sizes, args.max_repeats, tamaas_sign)
    case_self_affine(sa_sizes, args.max_repeats, tamaas_sign, args.tamaas_max_n, args.seed)
    case_iteration_growth(growth_sizes, (0, 1, 2))

    elapsed = time.perf_counter() - started
    print(f"total {elapsed:.0f} s; load average at end {os.getloadavg()[0]:.2f}")
    if args.json:
        meta = dict(roadtex=roadtex.__version__, tamaas=None if tm is None else tm.TamaasInfo.version,
                    tamaas_backend=None if tm is None else tm.TamaasInfo.backend, tamaas_sign=tamaas_sign,
                    python=platform.python_version(), numpy=np.__version__, cores=os.cpu_count(),
                    quick=args.quick, large=args.large, seed=args.seed, elapsed_s=elapsed)
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(dict(meta=meta, rows=ROWS), f, indent=1)
        print(f"rows written to {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
