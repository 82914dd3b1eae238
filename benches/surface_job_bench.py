"""Issue 17's target: a 1 m x 0.2 m surface at 0.5 mm (800,000 points), four E, areal and line
models, end to end through the bulk job (read, condition, tiles, solves, spectra, Parquet), with
the error budget off and on (the areal pilot, roadtex.budget.areal) in the same run.

    .venv/bin/python benches/surface_job_bench.py [--repeats 3]

A benchmark: it prints the wall time of each repeat and never fails on a number.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import polars as pl

import roadtex
from roadtex.surfaces import synthetic_surface


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    surface = synthetic_surface("dense_asphalt", 1.0, 0.2, 0.5e-3, seed=1)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        np.save(folder / "surface.npy", surface.heights)
        manifest = pl.DataFrame({"path": [str(folder / "surface.npy")], "format": ["surface"],
                                 "dx": [0.5e-3], "dy": [0.5e-3]})
        print(f"# {surface.heights.size:,} points, E = 1, 2, 5, 10 MPa, load average {os.getloadavg()[0]:.1f}")
        print("# each repeat: --error-budget off, then the default budget (the areal pilot), same run")
        for repeat in range(args.repeats):
            seconds = {}
            for budget in (None, roadtex.ProcessingOptions().error_budget_db):
                started = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", roadtex.errors.RoadtexWarning)
                    roadtex.process(manifest, folder / "out", roadtex.ProcessingOptions(error_budget_db=budget),
                                    quiet=True, force=True)
                label = "off" if budget is None else f"{budget:g} dB"
                seconds[label] = time.perf_counter() - started
                run = pl.read_parquet(folder / "out" / "runs.parquet").row(0, named=True)
                segments = pl.read_parquet(folder / "out" / "segments.parquet")
                models = segments["model"].value_counts().sort("model")
                print(f"repeat {repeat + 1}, budget {label}: {seconds[label]:.1f} s end to end; tol {run['tol_used']:g}, "
                      f"model grid k {run.get('refine')}, "
                      f"worst estimated error {run['worst_level_error_db']} dB, median iterations "
                      f"{segments['iterations'].median():g}; segment rows "
                      + ", ".join(f"{m}: {c}" for m, c in models.iter_rows()))
            off, on = seconds["off"], [v for k, v in seconds.items() if k != "off"][0]
            print(f"repeat {repeat + 1}: budget / off = {on / off:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
