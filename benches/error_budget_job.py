"""Error budget, job against job (issue 15, item 7): the default bulk job against the full-resolution
one (`--error-budget off --tol 1e-10`) on the three CAPTIF files, in the same run.

    .venv/bin/python benches/error_budget_job.py [--data ../shared/data/captif-slp] [--budget 0.2]

Prints the wall time of each job (pilot included), the ratio, and per band the stated error
(bands.parquet level_error_db) against the actual worst |level - full-resolution level| over every
segment, modulus and level kind. A benchmark: it prints, it never fails on a number.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
import warnings
from pathlib import Path

import polars as pl

import roadtex
from roadtex.archive import ProcessingOptions, build_manifest, process

LEVELS = ("texture_level", "enveloped_level", "pressure_level")


def job(manifest: pl.DataFrame, out: Path, options: ProcessingOptions) -> float:
    started = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", roadtex.errors.RoadtexWarning)
        process(manifest, out, options, quiet=True)
    return time.perf_counter() - started


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    here = Path(__file__).resolve().parents[1]
    parser.add_argument("--data", type=Path, default=here.parent / "shared" / "data" / "captif-slp")
    parser.add_argument("--budget", type=float, default=ProcessingOptions().error_budget_db)
    parser.add_argument("--json", type=Path, default=None, help="also write the per-band rows here")
    args = parser.parse_args()
    manifest = build_manifest(args.data)
    print(f"# {manifest.height} CAPTIF files, load average {os.getloadavg()[0]:.1f}, {time.strftime('%Y-%m-%d')}")
    with tempfile.TemporaryDirectory() as tmp:
        full_dir, budget_dir = Path(tmp) / "full", Path(tmp) / "budget"
        full_s = job(manifest, full_dir, ProcessingOptions(error_budget_db=None, tol=1e-10))
        budget_s = job(manifest, budget_dir, ProcessingOptions(error_budget_db=args.budget))
        plan = json.loads((budget_dir / "parameters.json").read_text())["plan"]
        full = pl.read_parquet(full_dir / "bands.parquet").filter(pl.col("reported"))
        mine = pl.read_parquet(budget_dir / "bands.parquet").filter(pl.col("reported"))
    keys = ["run_id", "segment", "youngs_modulus", "band"]
    joined = mine.join(full, on=keys, suffix="_full")
    diff = joined.with_columns(
        pl.max_horizontal(*[(pl.col(c) - pl.col(f"{c}_full")).abs() for c in LEVELS]).alias("actual"))
    per_band = (diff.group_by("band", "label").agg(pl.col("level_error_db").max().alias("stated"),
                                                    pl.col("actual").max(), pl.len().alias("rows"))
                .sort("band"))
    print(f"budget {args.budget} dB: dx {plan['dx'] * 1e3:.4g} mm, tol {plan['tol']:g}, within {plan['within_budget']}, "
          f"worst stated {plan['worst_error_db']:.3f} dB, pilot {plan['pilot_seconds']:.1f} s")
    print(f"full-resolution job {full_s:.1f} s, budget job {budget_s:.1f} s (pilot included): "
          f"{full_s / budget_s:.2f}x; rows compared: {joined.height} of {full.height}")
    print("| band | label (mm) | stated error (dB) | actual vs full (dB) |")
    print("|---|---|---|---|")
    for row in per_band.iter_rows(named=True):
        stated = "n/a" if row["stated"] is None else f"{row['stated']:.3f}"
        print(f"| {row['band']} | {row['label']} | {stated} | {row['actual']:.3f} |")
    if args.json:
        per_band.write_json(args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
