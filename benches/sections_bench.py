"""What the per-section indicators (sections.parquet, section_bands.parquet) cost the bulk job.

Run from the project root (a benchmark, not a test: it prints figures and never fails on them):

    .venv/bin/python benches/sections_bench.py            # 1 km at 0.5 mm, sections of 10 m
    .venv/bin/python benches/sections_bench.py --km 10    # the issue's 10 km archive (long)

It writes a synthetic archive (runs of 100 m of the four synthetic pavements at 0.5 mm; not
timed), then times ``roadtex.archive.process`` on it twice, each from scratch (``force``): with
the sections (the job as it is, ``--section-length``) and without them (the two section tables
replaced by empty ones, everything else the same). Settings: 0.5 m segments, E = 1, 2, 5, 10 MPa,
tol 1e-6, dx 0.5 mm, the model grid of the data (refine 1), no error budget (no pilot), local
engine. Wall times on a shared machine vary by several per cent between repeats: the difference
is also given from the section functions' own time, measured on every run.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import polars as pl

import roadtex.archive.compute as compute
from roadtex.archive import ProcessingOptions, process

DX = 5e-4
KINDS = ("dense_asphalt", "porous_asphalt", "cement_concrete", "surface_dressing")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--km", type=float, default=1.0, help="kilometres of profile (default 1)")
    parser.add_argument("--section-length", type=float, default=10.0, help="m (default 10)")
    parser.add_argument("--work", type=Path, default=Path("target/sections-bench"), help="work folder")
    args = parser.parse_args()
    from roadtex.demo import write_synthetic_archive

    runs = max(1, round(args.km * 10))
    manifest = write_synthetic_archive(args.work / "archive", kinds=KINDS, runs_per_kind=-(-runs // len(KINDS)),
                                       run_length=100.0, dx=DX)
    options = ProcessingOptions(youngs_moduli=(1e6, 2e6, 5e6, 1e7), tol=1e-6, dx=DX, refine=1, error_budget_db=None,
                                section_length=args.section_length)
    spent = []
    table, band_table = compute.section_table, compute.section_band_table

    def timed(function):
        def wrapper(*a, **k):
            start = time.perf_counter()
            try:
                return function(*a, **k)
            finally:
                spent.append(time.perf_counter() - start)
        return wrapper

    compute.section_table, compute.section_band_table = timed(table), timed(band_table)
    start = time.perf_counter()
    with_sections = process(manifest, args.work / "with", options, quiet=True, force=True)
    seconds_with = time.perf_counter() - start
    compute.section_table = lambda *a, **k: None
    compute.section_band_table = lambda *a, **k: None
    start = time.perf_counter()
    process(manifest, args.work / "without", options, quiet=True, force=True)
    seconds_without = time.perf_counter() - start
    compute.section_table, compute.section_band_table = table, band_table
    rows = pl.read_parquet(args.work / "with" / "sections.parquet").height
    print(f"{with_sections.kilometres:.3f} km in {with_sections.runs} runs, sections of {args.section_length:g} m "
          f"({rows} rows)")
    print(f"job with sections:    {seconds_with:7.1f} s")
    print(f"job without sections: {seconds_without:7.1f} s  (difference {seconds_with - seconds_without:+.1f} s, "
          f"{(seconds_with / seconds_without - 1) * 100:+.1f} %)")
    print(f"section functions' own time: {sum(spent):.2f} s ({sum(spent) / seconds_with * 100:.2f} % of the job), "
          f"over {len(spent) // 2} runs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
