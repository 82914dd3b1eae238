"""The local engine's schedule (issue 39): the job's own sharing of the cores between its runs in flight
(``roadtex.archive.engines.local_schedule`` and ``run_threads``: one run more than the cores, one
thread each) against the schedule before 0.5.8 (two runs in flight, each on every core), alternated
in one process on the same archive, with the same results bit for bit (checked here on bands.parquet).

    .venv/bin/python benches/local_schedule.py MANIFEST [--budget-off] [--repeats 4]

A first job makes the line pilots, which every later job of the folder keeps: the times are those of
the runs (reading, solving, spectra, writing) and the combining step. Surface runs make their own
pilot every time. A benchmark: it prints, it never fails on a number.
"""

from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

import polars as pl
from polars.testing import assert_frame_equal

import roadtex.archive.engines as engines
from roadtex.archive import ProcessingOptions, process

NEW_SCHEDULE, NEW_THREADS = engines.local_schedule, engines.run_threads


def use_schedule(name: str) -> None:
    """"new": this version's; "old": two runs in flight, each on every core (``threads`` None)."""
    if name == "old":
        engines.local_schedule = lambda threads, cores=None: engines.LOCAL_RUNS_IN_FLIGHT   # type: ignore[assignment]
        engines.run_threads = lambda threads, remaining, cores=None: threads               # type: ignore[assignment]
    else:
        engines.local_schedule, engines.run_threads = NEW_SCHEDULE, NEW_THREADS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("manifest")
    parser.add_argument("--budget-off", action="store_true", help="the data grid's job (--error-budget off)")
    parser.add_argument("--repeats", type=int, default=4)
    args = parser.parse_args()
    options = ProcessingOptions(error_budget_db=None) if args.budget_off else ProcessingOptions()
    out = Path(tempfile.mkdtemp(prefix="local-schedule-"))
    times: dict[str, list[float]] = {"old": [], "new": []}
    bands: dict[str, pl.DataFrame] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        process(args.manifest, out, options, quiet=True, force=True)   # the pilots, kept for the rest
        for _ in range(args.repeats):
            for name in ("old", "new"):
                use_schedule(name)
                started = time.perf_counter()
                process(args.manifest, out, options, quiet=True, force=True)
                times[name].append(time.perf_counter() - started)
                bands[name] = pl.read_parquet(out / "bands.parquet")
    use_schedule("new")
    assert_frame_equal(bands["old"], bands["new"], check_exact=True)
    cores = engines.usable_cores()
    print(f"{args.manifest} ({'data grid' if args.budget_off else 'default'}), {cores} cores: "
          f"{engines.local_schedule(None, cores)} runs in flight on {engines.run_threads(None, 100, cores)} thread(s) "
          f"each against {engines.LOCAL_RUNS_IN_FLIGHT} on every core")
    for name, label in (("old", "two runs, every core"), ("new", "this version")):
        print(f"  {label:<22} " + ", ".join(f"{t:.2f}" for t in times[name]) + " s")
    print("  the same bands.parquet, bit for bit")


if __name__ == "__main__":
    main()
