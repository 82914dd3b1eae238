"""Two builds of the Rust core against each other, alternated (a benchmark: it prints, it never fails
on a number).

    .venv/bin/python benches/core_ab.py job MANIFEST [MANIFEST ...] --builds BASE.so CANDIDATE.so [--pairs 4]
    .venv/bin/python benches/core_ab.py solves --builds BASE.so CANDIDATE.so [--pairs 3]
    .venv/bin/python benches/core_ab.py paired --builds BASE.so CANDIDATE.so [--pairs 15]

Make each build with ``maturin develop --release`` and copy ``python/roadtex/_core.abi3.so`` away
(the solver's constants are compiled in, so a Python-level switch cannot compare them). Every run is
a fresh process with that build swapped in (a new file renamed over the installed one, which is put
back at the end); the order is swapped every pair, so a machine's drift falls on both.

``job``: the bulk job (default options, pilots made each time, ``force=True``) on each manifest;
printed: every time, the medians and the k each run got. ``solves``: one thread, best of 5, a
model-grid solve of 0.5 m segments as the job makes it (four moduli chained, the data grid's answer
as the start, tol 1e-3) for cement concrete, dense and porous asphalt at 0.5 mm (k = 5) and 1 mm
(k = 8), and cold self-affine profiles of 2^12 and 2^14 points at tol 1e-8; printed: ms per batch
and mean iterations. The CPU clock of this machine steps by about 2 ms, so each batch is tens of ms.
``paired``: both builds loaded in this one process (each as its own module), the same batches
called alternately, build after build, ``--pairs`` times: one thread, four moduli chained, 0.5 m
segments of the four synthetic pavements at 0.5 mm (k = 4) and 1 mm (k = 6) from the data grid's
answer at tol 1e-3, and on the data grid at tol 1e-6; printed: the least time, the mean iterations,
the median of the per-pair time ratios (candidate / base: the machine's drift falls on both
alike, so this resolves a few per cent where whole processes move by a tenth) and the largest
pressure difference between the builds (of P).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

JOB = r"""
import json, sys, time, warnings
import polars as pl
from roadtex.archive import ProcessingOptions, process
started = time.perf_counter()
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    process(sys.argv[1], sys.argv[2], ProcessingOptions(), quiet=True, force=True)
seconds = time.perf_counter() - started
runs = pl.read_parquet(sys.argv[2] + "/runs.parquet")
print(json.dumps({"seconds": seconds, "k": sorted(set(runs["refine"].drop_nulls().to_list()))}))
"""

SOLVES = r"""
import importlib, json, time
import numpy as np
from roadtex import _core
from roadtex.models.grid import refine_periodic
from roadtex import synthetic_pavement
contact_many = importlib.import_module("roadtex.models.contact").contact_many
out = {}
def best(name, solve):
    times, batch = [], None
    for _ in range(5):
        started = time.perf_counter()
        batch = solve()
        times.append(time.perf_counter() - started)
    out[name] = [1e3 * min(times), float(np.mean(batch.iterations))]
moduli = [1e6, 2e6, 5e6, 1e7]
for kind in ("cement_concrete", "dense_asphalt", "porous_asphalt"):
    for dx, k in ((5e-4, 5), (1e-3, 8)):
        segments = synthetic_pavement(kind, 6.0, dx, seed=3).segments(0.5).heights
        fine = np.array([refine_periodic(segment, k) for segment in segments])
        best(f"{kind} {dx * 1e3:g} mm k={k}", lambda: contact_many(
            fine, dx / k, moduli, 2e5, tol=1e-3, threads=1, warm_start=True, coarse_start=k))
for log2 in (12, 14):
    n = 1 << log2
    segs = np.array([_core.self_affine_profile(n, 0.5, 0.8, 0.1, 0.25, seed) for seed in range(6)])
    best(f"self-affine 2^{log2} cold 1e-8", lambda: contact_many(segs, 0.5 / n, [1e6], 2e5, tol=1e-8, threads=1))
print(json.dumps(out))
"""


def installed_core() -> Path:
    """The extension module the venv imports (found in a child: this process never loads it)."""
    origin = subprocess.run([sys.executable, "-c", "import importlib.util as u; print(u.find_spec('roadtex._core').origin)"],
                            capture_output=True, text=True, check=True).stdout.strip()
    return Path(origin)


def swap_in(build: Path, target: Path) -> None:
    # A new file renamed over the old one: a process still mapping the old file keeps its pages.
    staged = target.with_suffix(".staged")
    shutil.copyfile(build, staged)
    os.chmod(staged, 0o755)
    os.replace(staged, target)


def run(code: str, *args: str) -> dict:
    result = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, check=True)
    return json.loads(result.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=("job", "solves", "paired"))
    parser.add_argument("manifests", nargs="*")
    parser.add_argument("--builds", nargs=2, required=True, type=Path, metavar=("BASE", "CANDIDATE"))
    parser.add_argument("--pairs", type=int, default=None)
    args = parser.parse_args()
    if args.what == "job" and not args.manifests:
        parser.error("job needs at least one manifest")
    pairs = args.pairs or {"job": 4, "solves": 3, "paired": 15}[args.what]
    if args.what == "paired":
        paired(args.builds, pairs)
        return
    target = installed_core()
    work = Path(tempfile.mkdtemp(prefix="core-ab-"))
    original = work / "installed.so"
    shutil.copyfile(target, original)
    # Keyed by role, not file name: a build against itself (the noise floor) stays two columns.
    roles = {"base": args.builds[0], "candidate": args.builds[1]}
    try:
        for manifest in args.manifests if args.what == "job" else [None]:
            results: dict[str, list[dict]] = {f"{role} ({build.name})": [] for role, build in roles.items()}
            for pair in range(pairs):
                for role in ("base", "candidate") if pair % 2 == 0 else ("candidate", "base"):
                    swap_in(roles[role], target)
                    runs = results[f"{role} ({roles[role].name})"]
                    runs.append(run(SOLVES) if manifest is None else run(JOB, manifest, str(work / f"out-{role}")))
            report(manifest, results)
    finally:
        swap_in(original, target)
        shutil.rmtree(work, ignore_errors=True)


def report(manifest: str | None, results: dict[str, list[dict]]) -> None:
    if manifest is not None:
        print(f"{manifest}:")
        for name, runs in results.items():
            seconds = [r["seconds"] for r in runs]
            print(f"  {name}: {', '.join(f'{s:.2f}' for s in seconds)} s, median {statistics.median(seconds):.2f} s; "
                  f"k {runs[-1]['k']}")
        return
    first = next(iter(results.values()))[0]
    print(f"{'case':36s}" + "".join(f"{name:>30s}" for name in results))
    for case in first:
        cells = []
        for runs in results.values():
            times = [r[case][0] for r in runs]
            cells.append(f"{statistics.median(times):9.1f} ms ({min(times):.1f}) {runs[-1][case][1]:5.1f} it")
        print(f"{case:36s}" + "".join(f"{c:>30s}" for c in cells))


def load_build(path: Path, tag: str):
    """The extension module in `path`, loaded as its own module (a package name of its own, the
    same init symbol): two builds side by side in one process."""
    import importlib.util
    spec = importlib.util.spec_from_file_location(f"{tag}._core", path)
    if spec is None or spec.loader is None:
        raise SystemExit(f"{path}: not an extension module")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def paired(builds: list[Path], pairs: int) -> None:
    import numpy as np

    from roadtex import synthetic_pavement
    from roadtex.models.grid import refine_periodic
    cores = {"base": load_build(builds[0], "base"), "candidate": load_build(builds[1], "candidate")}
    moduli = np.array([1e6, 2e6, 5e6, 1e7])
    cases = []
    for kind in ("cement_concrete", "dense_asphalt", "porous_asphalt", "surface_dressing"):
        for dx, k in ((5e-4, 4), (1e-3, 6)):
            segments = synthetic_pavement(kind, 4.0, dx, seed=3).segments(0.5).heights
            fine = np.ascontiguousarray([refine_periodic(segment, k) for segment in segments])
            cases.append((f"{kind} {dx * 1e3:g} mm k={k} 1e-3", fine, dx / k, 1e-3, k))
        data = np.ascontiguousarray(synthetic_pavement(kind, 4.0, 1e-3, seed=3).segments(0.5).heights)
        cases.append((f"{kind} 1 mm data grid 1e-6", data, 1e-3, 1e-6, None))
    print(f"{'case':40s}{'base':>26s}{'candidate':>26s}{'ratio':>8s}{'max|dp|/P':>11s}")
    for name, segments, dx, tol, k in cases:
        times: dict[str, list[float]] = {role: [] for role in cores}
        last: dict[str, tuple] = {}
        for pair in range(pairs):
            for role in ("base", "candidate") if pair % 2 == 0 else ("candidate", "base"):
                started = time.perf_counter()
                last[role] = cores[role].solve_many(segments, dx, moduli, 0.5, 2e5, True, "element", "cg", tol, 2000, 1,
                                                    True, k, None)
                times[role].append(time.perf_counter() - started)
        ratio = statistics.median(c / b for b, c in zip(times["base"], times["candidate"]))
        dp = float(np.abs(last["candidate"][0] - last["base"][0]).max()) / 2e5
        cells = "".join(f"{1e3 * min(times[r]):12.1f} ms {np.mean(last[r][2]):6.2f} it" for r in cores)
        print(f"{name:40s}{cells}{ratio:8.3f}{dp:11.1e}", flush=True)


if __name__ == "__main__":
    main()
