"""Areal contact: roadtex next to tamaas 2.9 (``model_type.basic_2d``, PolonskyKeerRey), in one run.

The issue's case: isotropic self-affine surfaces on an N x N periodic grid of side 1 (Hurst 0.8,
|h(q)| ~ |q|^-1.8 for 1 <= |q| < N/4, random phases, rms slope 0.1), E* = 1 (E = 0.75, nu = 0.5),
P = 0.01 (about 20 % contact), tol 1e-8 (``--tol`` for another, e.g. 1e-10: both solvers at the same
tol), seed 1.

Columns:
  time     best of up to 3 runs (1 for slow ones), kernel build included for roadtex (and the Model
           and solver set-up for tamaas).
  iters    roadtex CG iterations; tamaas Polonsky-Keer-Rey iterations (from its log).
  rt-sp vs tm  max|p_roadtex_spectral - p_tamaas| / P (the same discrete problem).
  el vs sp     max|p_element - p_spectral| / P (the two kernels' model difference, not an error).
  ratio    tamaas time / roadtex time, for each roadtex thread count.

Memory: ``--memory 2048`` solves one 2048^2 surface (element kernel) in a subprocess and prints its
peak RSS. Install the peer first: ``.venv/bin/python -m pip install -r scripts/requirements-bench.txt``.
Run: ``.venv/bin/python benches/surface_vs_tamaas.py [--sizes 128 256 512 1024] [--tol 1e-10] [--memory 2048]``.
"""

from __future__ import annotations

import argparse
import datetime
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from typing import Callable, Iterator, TypeVar

import numpy as np

import roadtex

T = TypeVar("T")
YOUNGS, POISSON, PRESSURE, TOL = 0.75, 0.5, 0.01, 1e-8


def self_affine_surface(n: int, seed: int = 1, hurst: float = 0.8, rms_slope: float = 0.1) -> np.ndarray:
    """The issue's surface on an n x n grid of side 1 (m), rows [iy, ix]."""
    rng = np.random.default_rng(seed)
    qx, qy = np.meshgrid(np.fft.rfftfreq(n, 1.0 / n), np.fft.fftfreq(n, 1.0 / n))
    q = np.hypot(qx, qy)
    band = (q >= 1) & (q < n / 4)
    amplitude = np.zeros_like(q)
    amplitude[band] = q[band] ** -(1.0 + hurst)
    h = np.fft.irfft2(amplitude * np.exp(2j * np.pi * rng.random(q.shape)), s=(n, n))
    dx = 1.0 / n
    slope2 = np.mean(((np.roll(h, -1, 1) - h) / dx) ** 2 + ((np.roll(h, -1, 0) - h) / dx) ** 2)
    return np.ascontiguousarray(h * rms_slope / np.sqrt(slope2))


def best_time(run: Callable[[], T], repeats: int) -> tuple[float, T]:
    best, result = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        result = run()
        elapsed = time.perf_counter() - start
        best = min(best, elapsed)
        if elapsed > 5.0:
            break
    assert result is not None
    return best, result


def solve_roadtex(h: np.ndarray, kernel: str, threads: int, tol: float = TOL) -> roadtex.SurfaceResult:
    n = h.shape[0]
    batch = roadtex.contact_surface_many(h[None], 1.0 / n, youngs_modulus=YOUNGS, poisson=POISSON,
                                         mean_pressure=PRESSURE, kernel=kernel, tol=tol, max_iterations=20000,
                                         threads=threads)
    return batch[0, 0]


@contextmanager
def captured_stderr_fd() -> Iterator[list[str]]:
    """What C++ code writes to file descriptor 2 (tamaas logs there)."""
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


def solve_tamaas(tm: object, h: np.ndarray, sign: float, tol: float = TOL) -> tuple[np.ndarray, int | None]:
    n = h.shape[0]
    surface = np.ascontiguousarray(sign * h).copy()
    with captured_stderr_fd() as log:
        model = tm.Model(tm.model_type.basic_2d, [1.0, 1.0], [n, n])  # type: ignore[attr-defined]
        model.E, model.nu = YOUNGS, POISSON
        solver = tm.PolonskyKeerRey(model, surface, tol, tm.PolonskyKeerRey.pressure,  # type: ignore[attr-defined]
                                    tm.PolonskyKeerRey.pressure)  # type: ignore[attr-defined]
        solver.max_iter = 100000
        solver.dump_freq = 100001
        solver.solve(PRESSURE)
        traction = np.array(model.traction, dtype=np.float64, copy=True).reshape(n, n)
    last = None
    for line in (log[0] if log else "").splitlines():
        m = _LOG_LINE.match(line)
        if m:
            last = int(m.group(1))
    return traction, None if last is None else last + 1


def memory(n: int) -> None:
    """Solves one n x n surface in a child process and prints its peak RSS."""
    code = (f"import sys; sys.path.insert(0, {os.path.dirname(os.path.abspath(__file__))!r});"
            f"import surface_vs_tamaas as b, roadtex, time, resource; h = b.self_affine_surface({n}); t = time.perf_counter();"
            f"r = roadtex.contact_surface(h, 1.0 / {n}, youngs_modulus=b.YOUNGS, poisson=b.POISSON,"
            f" mean_pressure=b.PRESSURE, tol=b.TOL, max_iterations=20000);"
            "print(f'{r.iterations} iterations, {time.perf_counter() - t:.1f} s, contact {r.contact_fraction:.3f}, '"
            "f'peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20:.2f} GiB')")
    print(f"memory, N = {n}^2 (element kernel, default threads):", flush=True)
    subprocess.run([sys.executable, "-c", code], check=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[128, 256, 512, 1024])
    parser.add_argument("--memory", type=int, nargs="*", default=[])
    parser.add_argument("--tol", type=float, default=TOL, help="both solvers' tol (default 1e-8, the issue's)")
    args = parser.parse_args()
    tol = args.tol
    try:
        import tamaas as tm
    except Exception as exc:  # ImportError, or tamaas failing to load its extension
        tm = None
        print(f"tamaas unavailable ({exc}); roadtex only")
    print(f"surface_vs_tamaas, {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
          f"{os.cpu_count()} cores (shared, load average {' '.join(f'{x:.1f}' for x in os.getloadavg())}), "
          f"tol {tol:g}; tamaas {getattr(tm, '__version__', '-')} one thread")
    sign = 1.0
    if tm is not None:
        h = self_affine_surface(64)
        rt = solve_roadtex(h, "spectral", 1)
        diffs = {s: np.max(np.abs(solve_tamaas(tm, h, s)[0] - rt.pressure)) / PRESSURE for s in (1.0, -1.0)}
        sign = min(diffs, key=lambda s: diffs[s])
        print(f"problem check (64^2): max|dp|/P heights as given {diffs[1.0]:.1e}, negated {diffs[-1.0]:.1e}")
    header = ("N", "contact", "rt-sp 1t", "rt-el 1t", "rt-sp 2t", "rt-el 2t", "iters sp/el", "tamaas",
              "tm iters", "sp vs tm", "el vs sp", "tm/sp 1t", "tm/el 1t", "tm/sp 2t", "tm/el 2t")
    print(" | ".join(header))
    for n in args.sizes:
        h = self_affine_surface(n)
        repeats = 3 if n <= 512 else 1
        times, results = {}, {}
        for threads in (1, 2):
            for kernel in ("spectral", "element"):
                times[kernel, threads], results[kernel, threads] = best_time(
                    lambda: solve_roadtex(h, kernel, threads, tol), repeats)  # noqa: B023
        sp, el = results["spectral", 1], results["element", 1]
        assert np.array_equal(sp.pressure, results["spectral", 2].pressure), "thread count changed the result"
        row = [f"{n}^2", f"{sp.contact_fraction:.3f}"] + [f"{times[k, t]:.3f} s" for t in (1, 2)
                                                           for k in ("spectral", "element")]
        row.append(f"{sp.iterations}/{el.iterations}")
        el_vs_sp = np.max(np.abs(el.pressure - sp.pressure)) / PRESSURE
        if tm is not None:
            tm_time, (tm_p, tm_iters) = best_time(lambda: solve_tamaas(tm, h, sign, tol), 1 if n >= 512 else repeats)
            row += [f"{tm_time:.2f} s", str(tm_iters), f"{np.max(np.abs(tm_p - sp.pressure)) / PRESSURE:.1e}",
                    f"{el_vs_sp:.1e}"]
            row += [f"{tm_time / times[k, t]:.1f}x" for t in (1, 2) for k in ("spectral", "element")]
        else:
            row += ["-", "-", "-", f"{el_vs_sp:.1e}"] + ["-"] * 4
        print(" | ".join(row), flush=True)
    print(f"load average at the end: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    for n in args.memory:
        memory(n)
    print(f"(this process: peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20:.2f} GiB)")


if __name__ == "__main__":
    main()
