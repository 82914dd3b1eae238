"""The model grid (issue 34): the default job (the pilot chooses k) against the data's own grid
(``refine=1``, today's solve), in the same run, on the demo's archive and a synthetic archive at 0.5 mm.

    .venv/bin/python benches/model_grid.py                 # the demo's archive and 10 km at 0.5 mm
    .venv/bin/python benches/model_grid.py --km 1 --check-runs 2

For each archive and job: wall time (pilot included, and the pilot alone), the model grid chosen
(dx, k, tol), and per budget band the stated error (bands.parquet ``level_error_db``) against the
actual worst |level - level at k = 32| over every segment, modulus and level kind of --check-runs
runs (solved here independently: numpy's linear interpolation, tol 1e-10), and the interpolant
spread (what the sampling cannot tell). A benchmark: it prints, it never fails on a number.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import polars as pl

import roadtex
from roadtex.archive import ProcessingOptions, process
from roadtex.demo import write_synthetic_archive
from roadtex.spectra.bands import REFERENCE_PRESSURE

TRUTH_REFINE = 32


def linear_road(heights: np.ndarray, refine: int) -> np.ndarray:
    n = heights.shape[1]
    fine = np.arange(n * refine) / refine
    return np.array([np.interp(fine, np.arange(n + 1), np.append(row, row[0])) for row in heights])


def truth_levels(path: str, dx: float, options: ProcessingOptions) -> pl.DataFrame:
    """(segment, youngs_modulus, band) -> enveloped and pressure levels at k = 32, tol 1e-10."""
    profile = roadtex.read_profile(path)
    cleaned, _ = roadtex.profiles.conditioning.clean(profile, spike_alpha=options.spike_alpha, warn=False)
    segments = cleaned.finished(dx=dx).segments(options.segment_length)
    moduli = np.asarray(options.youngs_moduli)
    fine = linear_road(segments.heights, TRUTH_REFINE)
    batch = roadtex.contact_many(fine, segments.dx / TRUTH_REFINE, moduli, options.mean_pressure, tol=1e-10,
                                 warm_start=True, raise_on_nonconvergence=False)
    n = fine.shape[0] * moduli.size
    env = roadtex.band_levels(batch.envelope.reshape(n, -1), segments.dx / TRUTH_REFINE, periodic=True)
    pr = roadtex.band_levels(batch.pressure.reshape(n, -1), segments.dx / TRUTH_REFINE, periodic=True,
                             reference=REFERENCE_PRESSURE)
    bands = env.bands["band"].to_list()
    return pl.DataFrame({
        "segment": np.repeat(np.repeat(np.arange(fine.shape[0]), moduli.size), len(bands)),
        "youngs_modulus": np.repeat(np.tile(moduli, fine.shape[0]), len(bands)),
        "band": np.tile(bands, n),
        "enveloped_truth": env.levels.ravel(), "pressure_truth": pr.levels.ravel(),
    })


def run_job(manifest: Path, out: Path, options: ProcessingOptions) -> dict:
    started = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        process(manifest, out, options, quiet=True, force=True)
    seconds = time.perf_counter() - started
    plan = json.loads((out / "parameters.json").read_text())["plan"]
    return {"seconds": seconds, "pilot_seconds": plan["pilot_seconds"], "dx": plan["dx"], "refine": plan["refine"],
            "tol": plan["tol"], "worst_stated": plan["worst_error_db"]}


def actual_per_band(out: Path, check_runs: int, options: ProcessingOptions) -> pl.DataFrame:
    runs = pl.read_parquet(out / "runs.parquet").filter(pl.col("dx_used").is_not_null())
    picks = runs[np.unique(np.linspace(0, runs.height - 1, min(check_runs, runs.height)).round().astype(int))]
    bands = pl.read_parquet(out / "bands.parquet")
    frames = []
    for run in picks.iter_rows(named=True):
        truth = truth_levels(run["path"], run["dx_used"], options)
        rows = bands.filter((pl.col("run_id") == run["run_id"]) & pl.col("reported")).join(
            truth, on=["segment", "youngs_modulus", "band"], how="inner")
        frames.append(rows.select("band", "label", "level_error_db", "interpolant_spread_db",
                                  (pl.col("enveloped_level") - pl.col("enveloped_truth")).abs().alias("env"),
                                  (pl.col("pressure_level") - pl.col("pressure_truth")).abs().alias("prs")))
    table = pl.concat(frames)
    return (table.group_by("band", "label").agg(pl.col("level_error_db").max().alias("stated"),
                                               pl.max_horizontal(pl.col("env").max(), pl.col("prs").max()).alias("actual"),
                                               pl.col("interpolant_spread_db").max().alias("spread"))
            .sort("band"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--km", type=float, default=10.0, help="length of the synthetic 0.5 mm archive (km)")
    parser.add_argument("--check-runs", type=int, default=3, help="runs checked against k = 32 per archive")
    parser.add_argument("--work", default=None, help="folder for the archives (default: a temporary one)")
    args = parser.parse_args()
    work = Path(args.work or tempfile.mkdtemp(prefix="model-grid-"))
    archives = {"demo (6 runs x 4 m, 0.5 mm)": write_synthetic_archive(work / "demo"),
                f"{args.km:g} km at 0.5 mm": write_synthetic_archive(
                    work / "archive", kinds=("dense_asphalt", "porous_asphalt", "cement_concrete", "surface_dressing"),
                    runs_per_kind=max(1, round(args.km * 1000 / 20 / 4)), run_length=20.0, dx=0.5e-3)}
    budget = roadtex.budget.DEFAULT_ERROR_BUDGET_DB
    for name, manifest in archives.items():
        print(f"\n== {name} (budget {budget:g} dB) ==")
        results = {}
        for label, options in (("data grid (k = 1)", ProcessingOptions(refine=1)),
                               ("model grid (pilot)", ProcessingOptions())):
            out = work / f"out-{abs(hash((name, label)))}"
            results[label] = run_job(manifest, out, options)
            r = results[label]
            print(f"{label:<20} {r['seconds']:7.1f} s (pilot {r['pilot_seconds']:.1f} s)  dx {r['dx'] * 1e3:.3g} mm  "
                  f"k {r['refine']}  tol {r['tol']:g}  worst stated {r['worst_stated']:.3f} dB")
            table = actual_per_band(out, args.check_runs, options)
            budget_bands = set(roadtex.budget.budget_bands(r["dx"], options.segment_length)["band"].to_list())
            inside = table.filter(pl.col("band").is_in(list(budget_bands)))
            print("   band (mm)  stated  actual  stated/actual  interpolant spread (dB)")
            for row in inside.iter_rows(named=True):
                ratio = row["stated"] / max(row["actual"], 1e-3)
                spread = row["spread"] if row["spread"] is not None else float("nan")
                print(f"   {row['label']:>8} {row['stated']:7.3f} {row['actual']:7.3f} {ratio:10.1f} {spread:12.2f}")
        ratio = results["model grid (pilot)"]["seconds"] / results["data grid (k = 1)"]["seconds"]
        print(f"time ratio, model grid / data grid: {ratio:.2f}")


if __name__ == "__main__":
    main()
