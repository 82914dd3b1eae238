"""0.5.9's two pilot changes against what they replaced, alternated in one process (a benchmark: it
prints, it never fails on a number).

    .venv/bin/python benches/pilot_variants.py ladder MANIFEST [MANIFEST ...] [--pairs 4]
    .venv/bin/python benches/pilot_variants.py top-rung MANIFEST [--pairs 4]

``ladder``: the line pilot's model grids with k = 5, 10 and 20 (0.5.9) against without them (0.5.8);
``top-rung``: the areal pilot's finest rung carried on from its job-like solve (0.5.9) against its
reference from a nested start (0.5.8). Each pair runs both jobs (default options, pilots made each
time, ``force=True``) in fresh folders, the order swapped every pair; printed: every time, the
medians, and the k each run got.
"""

from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import polars as pl

import roadtex.budget.areal as areal
import roadtex.budget.pilot as pilot
import roadtex.budget.study as study
from roadtex.archive import ProcessingOptions, process

LADDER_058 = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32)
LADDER_059 = study.REFINE_LADDER
TOP_RUNG_059 = areal.top_rung_needed


def use(variant: str, new: bool) -> None:
    if variant == "ladder":
        study.REFINE_LADDER = pilot.REFINE_LADDER = LADDER_059 if new else LADDER_058
    else:
        areal.top_rung_needed = TOP_RUNG_059 if new else (lambda *args: False)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("variant", choices=("ladder", "top-rung"))
    parser.add_argument("manifests", nargs="+")
    parser.add_argument("--pairs", type=int, default=4)
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="pilot-variants-"))
    for manifest in args.manifests:
        times: dict[str, list[float]] = {"0.5.8": [], "0.5.9": []}
        for pair in range(args.pairs):
            order = ("0.5.8", "0.5.9") if pair % 2 == 0 else ("0.5.9", "0.5.8")
            for name in order:
                use(args.variant, name == "0.5.9")
                out = work / f"{Path(manifest).parent.name}-{name}"
                started = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    process(manifest, out, ProcessingOptions(), quiet=True, force=True)
                times[name].append(time.perf_counter() - started)
        use(args.variant, True)
        print(f"{manifest} ({args.variant}, {args.pairs} pairs):")
        for name, values in times.items():
            runs = pl.read_parquet(work / f"{Path(manifest).parent.name}-{name}" / "runs.parquet")
            ks = sorted(set(runs["refine"].drop_nulls().to_list()))
            print(f"  {name}: {', '.join(f'{t:.1f}' for t in values)} s, median {np.median(values):.2f} s; k {ks}")


if __name__ == "__main__":
    main()
