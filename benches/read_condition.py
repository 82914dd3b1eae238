"""Time to read and condition a 2,000,000-point profile (target: under 1 s).

    .venv/bin/python benches/read_condition.py [--points 2000000] [--repeat 3]

Writes one synthetic raw profile (CAPTIF-like: 0.0375 mm sampling, positions rounded to 1 um,
about 9 % drop-outs, some spikes, reference plates at both ends) as a CAPTIF text file, a CSV, a
.npy and a Parquet file in a temporary folder, then times read_profile and Profile.conditioned
(trim plates, resample, spikes, fill, detrend; and the same at 0.5 mm with the 2.4 mm low-pass)
for each. The best of ``--repeat`` runs is reported.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from roadtex.profiles import Profile, read_profile, write_profile
from roadtex.profiles.pavements import synthetic_pavement


def raw_profile(points: int, seed: int = 0) -> Profile:
    dx = 0.0375e-3
    road = synthetic_pavement("surface_dressing", points * dx, dx, seed=seed).heights
    rng = np.random.default_rng(seed)
    z = road.copy()
    z[rng.random(points) < 0.09] = np.nan
    z[rng.integers(0, points, points // 2000)] += 6e-3            # spikes
    plate = int(0.04 / dx)
    z[int(0.02 / dx):int(0.02 / dx) + plate] = np.nan               # plates: drop-outs with 47 mm edges
    z[int(0.02 / dx):int(0.02 / dx) + 20] = 0.047
    z[-int(0.02 / dx) - plate:-int(0.02 / dx)] = np.nan
    z[-int(0.02 / dx) - 20:-int(0.02 / dx)] = 0.047
    x = np.round(np.arange(points) * dx, 6)
    return Profile(z, x, dx, {"site": "bench"})


def write_captif(profile: Profile, path: Path) -> None:
    head = ("Road Name\tBENCH\t\r\nRef Station\t0\t\r\nStart Pos (m)\t0\t\r\nEnd Pos (m)\t0\t\r\n"
            "Direction\tincreasing\t\r\nWheel Path\tLeft\t\r\nDate\t11/10/2021\t\r\nFile No.\t0\t\r\n"
            "Current Pos\t0.0\t\r\n*****DATA*****\t\t\r\nData Point No:\tDistance (mm)\tDepth (mm)\r\n")
    rows = np.column_stack([np.arange(1, len(profile) + 1), profile.positions * 1e3, profile.heights * 1e3])
    with path.open("w", newline="") as handle:
        handle.write(head)
        np.savetxt(handle, rows, fmt=["%.3f", "%.3f", "%.3f"], delimiter="\t", newline="\r\n")


def best_of(repeat: int, task) -> tuple[float, object]:
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = task()
        times.append(time.perf_counter() - start)
    return min(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", type=int, default=2_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    profile = raw_profile(args.points)
    with tempfile.TemporaryDirectory() as folder:
        paths = {"captif": Path(folder) / "raw.dat"}
        write_captif(profile, paths["captif"])
        for fmt, suffix in (("csv", "csv"), ("npy", "npy"), ("parquet", "parquet")):
            paths[fmt] = write_profile(profile, Path(folder) / f"raw.{suffix}")
        print(f"{args.points:,} points, {profile.length:.1f} m, {profile.dropout_fraction:.1%} drop-outs; best of {args.repeat}")
        print(f"{'format':8s} {'file MB':>8s} {'read':>8s} {'condition':>10s} {'total':>8s}   "
              f"{'condition at 0.5 mm + low-pass':>30s}")
        for fmt, path in paths.items():
            read_s, loaded = best_of(args.repeat, lambda: read_profile(path))
            cond_s, conditioned = best_of(args.repeat, lambda: loaded.conditioned())
            coarse_s, _ = best_of(args.repeat, lambda: loaded.conditioned(dx=0.5e-3, lowpass_wavelength=2.4e-3))
            assert not np.isnan(conditioned.heights).any() and conditioned.is_uniform
            size = path.stat().st_size / 1e6
            print(f"{fmt:8s} {size:8.1f} {read_s:7.3f}s {cond_s:9.3f}s {read_s + cond_s:7.3f}s   {coarse_s:29.3f}s")


if __name__ == "__main__":
    main()
