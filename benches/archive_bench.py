"""The bulk job end to end on a synthetic archive, against a plain Python loop calling tamaas.

Run from the project root (a benchmark, not a test: it prints figures and never fails on them):

    .venv/bin/python benches/archive_bench.py            # 10 km at 0.5 mm: 20 million points
    .venv/bin/python benches/archive_bench.py --km 1     # a quicker look

What it does:
  1. Writes a synthetic archive (if not already there, in --work): runs of --run-length m of the
     project's synthetic pavements (dense asphalt, porous asphalt, cement concrete, surface
     dressing in turn; runs rounded up to whole sets of four) at dx = 0.5 mm, as Parquet profile
     files, and a manifest. Writing is not timed.
  2. Runs ``roadtex.archive.process`` on it (local engine, all cores, 0.5 m segments, E = 1, 2, 5
     and 10 MPa, P = 0.2 MPa, tol 1e-6): wall time end to end (reading, conditioning, MPD,
     segmenting, contact, spectra, Parquet), peak resident memory of this process.
  3. The same contact work done the plain way: a Python loop calling tamaas 2.9.0
     (PolonskyKeerRey, the spectral kernel, one model per segment length, tol 1e-6 on its own
     error measure) per segment and modulus, one thread. Solving all 160,000 problems that way
     would take hours, so the loop runs on --tamaas-sample segments drawn evenly from the archive
     and the total is extrapolated (stated in the output). Reading and spectra are not included
     on the tamaas side, which favours it.
Targets from issue 6: under 60 s end to end, peak memory under 2 GiB.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np
import polars as pl

DX = 5e-4
MODULI = (1e6, 2e6, 5e6, 1e7)
PRESSURE = 2e5
KINDS = ("dense_asphalt", "porous_asphalt", "cement_concrete", "surface_dressing")


def write_archive(folder: Path, km: float, run_length: float) -> Path:
    from roadtex.demo import write_synthetic_archive

    runs = max(1, round(km * 1000 / run_length))
    per_kind = -(-runs // len(KINDS))
    return write_synthetic_archive(folder, kinds=KINDS, runs_per_kind=per_kind, run_length=run_length, dx=DX)


def peak_memory_gib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20  # ru_maxrss is in KiB on Linux


def tamaas_loop(segments: np.ndarray, tol: float) -> float:
    """Seconds for a plain Python loop of tamaas solves over segments x moduli."""
    import tamaas as tm

    tm.set_log_level(tm.LogLevel.error)
    n = segments.shape[1]
    length = n * DX
    start = time.perf_counter()
    for heights in segments:
        for modulus in MODULI:
            surface = np.ascontiguousarray(heights, dtype=np.float64).copy()
            model = tm.Model(tm.model_type.basic_1d, [length], [n])
            model.E, model.nu = modulus, 0.5
            solver = tm.PolonskyKeerRey(model, surface, tol, tm.PolonskyKeerRey.pressure, tm.PolonskyKeerRey.pressure)
            solver.solve(PRESSURE)
    return time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--km", type=float, default=10.0, help="kilometres of profile (default 10)")
    parser.add_argument("--run-length", type=float, default=100.0, help="metres per run file (default 100)")
    parser.add_argument("--work", type=Path, default=Path("target/archive-bench"), help="work folder")
    parser.add_argument("--tamaas-sample", type=int, default=100, help="segments solved with tamaas (default 100)")
    parser.add_argument("--engine", choices=["local", "dask"], default="local")
    args = parser.parse_args()

    from roadtex.archive import ProcessingOptions, process, remove_outputs

    manifest = write_archive(args.work / "archive", args.km, args.run_length)
    out = args.work / "out"
    remove_outputs(out)
    options = ProcessingOptions(youngs_moduli=MODULI, mean_pressure=PRESSURE, segment_length=0.5, tol=1e-6)
    memory_before = peak_memory_gib()
    start = time.perf_counter()
    summary = process(manifest, out, options, engine=args.engine, quiet=True)
    elapsed = time.perf_counter() - start
    segments = pl.read_parquet(out / "segments.parquet")
    points = int(pl.read_parquet(out / "runs.parquet")["points"].sum())
    problems = segments.height
    print(f"roadtex archive benchmark: {summary.runs} runs, {summary.kilometres:.2f} km, {points / 1e6:.1f} M points, "
          f"{problems} contact problems (segments x {len(MODULI)} moduli), {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.2f}")
    print(f"  roadtex process ({args.engine}): {elapsed:.1f} s end to end (target < 60 s), "
          f"{elapsed / problems * 1e3:.3f} ms per problem, peak memory {peak_memory_gib():.2f} GiB "
          f"(before the job {memory_before:.2f} GiB; target < 2 GiB)")
    print(f"  iterations: median {segments['iterations'].median():.0f}, max {segments['iterations'].max()}; "
          f"worst residual {segments['residual'].max():.2e}; converged {segments['converged'].mean() * 100:.2f} %")

    if args.tamaas_sample > 0:
        try:
            import tamaas  # noqa: F401
        except Exception as exc:
            print(f"  tamaas loop: skipped, tamaas not importable ({exc}); pip install -r scripts/requirements-bench.txt")
            return 0
        from roadtex.profiles import read_profile

        table = pl.read_csv(manifest)
        picks = np.linspace(0, table.height - 1, min(args.tamaas_sample, table.height)).round().astype(int)
        sample = []
        for i in picks:
            profile = read_profile(manifest.parent / table["path"][int(i)]).conditioned()
            segs = profile.segments(0.5).heights
            sample.append(segs[len(segs) // 2])
        while len(sample) < args.tamaas_sample:
            sample.extend(sample[: args.tamaas_sample - len(sample)])
        sample_array = np.stack(sample)
        seconds = tamaas_loop(sample_array, 1e-6)
        per_problem = seconds / (sample_array.shape[0] * len(MODULI))
        extrapolated = per_problem * problems
        print(f"  tamaas loop (one thread, contact only): {per_problem * 1e3:.2f} ms per problem on {sample_array.shape[0]} "
              f"segments x {len(MODULI)} moduli; extrapolated to the archive: {extrapolated:.0f} s "
              f"= {extrapolated / elapsed:.0f}x roadtex's end-to-end time")
    return 0


if __name__ == "__main__":
    sys.exit(main())
