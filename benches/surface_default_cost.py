"""What a 1 mm surface run costs by default against the data's grid, and where the time goes (issue 40).

    .venv/bin/python benches/surface_default_cost.py [--threads 1] [--cases demo,extra]

The demo's three surfaces (cement concrete, dense asphalt, porous asphalt; 0.5 m x 40 mm at 1 mm,
seeds 1000 to 1002 as ``roadtex demo`` writes them) and two others (a surface dressing of seed 7 and a
porous asphalt of seed 11, same size), each through the job's surface run
(:func:`roadtex.archive.surface_run.compute_surface_run`: read, condition, tiles, solves, spectra),
E = 1, 2, 5, 10 MPa, P = 0.2 MPa:

  data     the error budget off: the data's grid (k = 1), tol 1e-6, no pilot.
  default  the default budget (0.2 dB): the areal pilot chooses k and tol, then the job solves.

Printed per surface: each setting's time, the pilot's share and the job's areal solve (its grid
and total CG iterations over the moduli), default / data, the chosen k and tol and the worst stated
error in the budget bands (dB). A benchmark: it prints figures and never fails on them.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

import roadtex.archive.surface_run as surface_run
from roadtex.archive import ProcessingOptions
from roadtex.surfaces import synthetic_surface

DEMO = (("cement_concrete", 1000), ("dense_asphalt", 1001), ("porous_asphalt", 1002))
EXTRA = (("surface_dressing", 7), ("porous_asphalt", 11))
SIZE, DX = (0.5, 0.04), 1e-3


class Timed:
    """Wraps the surface run's pilot and areal solves to time them (and count the solves' iterations)."""

    def __init__(self) -> None:
        self.pilot = 0.0
        self.solves: list[tuple[tuple[int, ...], float, int]] = []
        self.pilot_errors, self.solve = surface_run.pilot_errors, surface_run.contact_surface_many

    def __enter__(self) -> "Timed":
        def pilot(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return self.pilot_errors(*args, **kwargs)
            finally:
                self.pilot += time.perf_counter() - start

        def solve(heights: np.ndarray, *args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            result = self.solve(heights, *args, **kwargs)
            self.solves.append((heights.shape, time.perf_counter() - start, int(np.asarray(result.iterations).sum())))
            return result

        surface_run.pilot_errors, surface_run.contact_surface_many = pilot, solve
        return self

    def __exit__(self, *exc: object) -> None:
        surface_run.pilot_errors, surface_run.contact_surface_many = self.pilot_errors, self.solve


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--cases", default="demo,extra")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    cases = [c for name in args.cases.split(",") for c in {"demo": DEMO, "extra": EXTRA}[name]]
    options = ProcessingOptions(youngs_moduli=(1e6, 2e6, 5e6, 10e6), mean_pressure=2e5)
    settings = {"data": ProcessingOptions(**{**options.__dict__, "error_budget_db": None}), "default": options}
    print(f"# {SIZE[0]} m x {SIZE[1] * 1e3:g} mm at {DX * 1e3:g} mm, {args.threads} thread(s), "
          f"load average {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory() as tmp:
        for kind, seed in cases:
            path = Path(tmp) / f"{kind}_{seed}.npy"
            np.save(path, synthetic_surface(kind, *SIZE, DX, seed=seed).heights)
            run = {"path": str(path), "run_id": path.stem, "format": "surface", "dx": DX, "dy": DX}
            seconds = {}
            for label, opts in settings.items():
                with Timed() as timed:
                    start = time.perf_counter()
                    out = surface_run.compute_surface_run(run, opts, threads=args.threads)
                    seconds[label] = time.perf_counter() - start
                table = out["run"]
                errors = out["level_errors"]
                worst = float("nan") if errors is None else float(
                    errors.filter(errors["in_budget"])["level_error_db"].max())
                solves = ", ".join(f"{'x'.join(map(str, s[1:]))} {t:.1f} s {i} it" for s, t, i in timed.solves)
                print(f"{kind} seed {seed} {label:7s}: {seconds[label]:6.1f} s (pilot {timed.pilot:5.1f} s; job solves "
                      f"{solves}); k {table['refine'][0]}, tol {table['tol_used'][0]:g}, worst stated {worst:.2f} dB",
                      flush=True)
            print(f"  default / data: {seconds['default'] / seconds['data']:.0f}x", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
