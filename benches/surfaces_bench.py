"""Synthetic 3D surfaces and their conditioning at the issue-17 size (1 m x 0.2 m at 0.5 mm, 800,000
points), side by side with a floor measured in the same run.

Run from the project root (a benchmark, not a test: it prints figures and never fails on them):

    .venv/bin/python benches/surfaces_bench.py [--repeat 3] [--dx 0.5e-3]

For each step: the best of --repeat wall times, and its ratio to the floor, one real 2-D FFT and
its inverse of the same grid (``np.fft.rfft2``/``irfft2``: the least any step that touches every
point with a global operation costs). The error column says what each step gets right on this
data: for synthetic surfaces, the MPD of every 20th line (mm, ISO 13473-1) and whether it lies in
the line generator's range; for the conditioning steps, a check against an independent result.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from roadtex.profiles import mpd
from roadtex.surfaces import Surface, synthetic_surface

RANGES = {"dense_asphalt": (0.5, 1.0), "porous_asphalt": (1.2, 2.0), "surface_dressing": (1.5, 3.0),
          "cement_concrete": (0.3, 0.6), "cement_concrete+tining": (0.6, 1.2)}


def best(function, repeat: int) -> tuple[float, object]:
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - start)
    return min(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--dx", type=float, default=0.5e-3)
    args = parser.parse_args()
    dx, repeat = args.dx, args.repeat
    shape = (int(round(0.2 / dx)), int(round(1.0 / dx)))
    grid = np.random.default_rng(0).standard_normal(shape)
    floor, _ = best(lambda: np.fft.irfft2(np.fft.rfft2(grid), shape), repeat)
    print(f"grid {shape[0]} x {shape[1]} = {grid.size:,} points; floor (rfft2 + irfft2) {floor * 1e3:.1f} ms")
    print(f"{'step':<42}{'time (ms)':>10}{'x floor':>9}   error / check")
    rows = []
    for label, (low, high) in RANGES.items():
        kind, _, extra = label.partition("+")
        options = {"tining": True} if extra else {}
        seconds, surface = best(lambda: synthetic_surface(kind, 1.0, 0.2, dx, seed=0, **options), repeat)
        values = [mpd(line).mpd * 1e3 for line in surface.lines(every=20)]
        inside = low <= float(np.mean(values)) <= high
        rows.append((f"synthetic_surface {label}", seconds,
                     f"MPD {np.mean(values):.2f} mm (lines {min(values):.2f}..{max(values):.2f}), "
                     f"range {low}..{high}: {'in' if inside else 'OUT'}"))
    base = synthetic_surface("dense_asphalt", 1.0, 0.2, dx, seed=0)
    holed = base.heights.copy()
    rng = np.random.default_rng(1)
    holed.ravel()[rng.choice(holed.size, holed.size // 50, replace=False)] = np.nan
    spiked = base.heights.copy()
    where = rng.choice(spiked.size, 100, replace=False)
    spiked.ravel()[where] += 5e-3
    with_holes, with_spikes = Surface(holed, dx, dx), Surface(spiked, dx, dx)
    seconds, filled = best(with_holes.fill_dropouts, repeat)
    rows.append(("fill_dropouts (2 % drop-outs)", seconds, f"NaN left {int(np.isnan(filled.heights).sum())}"))
    seconds, cleaned = best(with_spikes.remove_spikes, repeat)
    found = np.isnan(cleaned.heights)
    rows.append(("remove_spikes (100 spikes of 5 mm)", seconds,
                 f"found {int(found.ravel()[where].sum())}/100, others flagged {int(found.sum() - found.ravel()[where].sum())}"))
    y, x = np.mgrid[0:shape[0], 0:shape[1]] * dx
    tilted = Surface(base.heights + 0.01 * x - 0.02 * y, dx, dx)
    seconds, flat = best(tilted.remove_plane, repeat)
    rows.append(("remove_plane", seconds, f"max |result - texture's own plane-free| "
                 f"{np.max(np.abs(flat.heights - base.remove_plane().heights)):.1e} m"))
    seconds, coarse = best(lambda: base.resample(1e-3), repeat)
    blocks = base.heights[: shape[0] // 2 * 2, : shape[1] // 2 * 2].reshape(shape[0] // 2, 2, shape[1] // 2, 2).mean(axis=(1, 3))
    rows.append(("resample to 1 mm", seconds, f"max |result - 2x2 block means| {np.max(np.abs(coarse.heights - blocks)):.1e} m"))
    seconds, lines = best(base.lines, repeat)
    rows.append((f"lines() ({len(lines)} profiles)", seconds, "rows"))
    seconds, tiles = best(lambda: base.tiles(0.1, 0.1, 0.01), repeat)
    rows.append((f"tiles 0.1 x 0.1 m, 10 mm overlap ({len(tiles)})", seconds, "planes removed"))
    seconds, stitched = best(lambda: tiles.stitch(tiles.heights, add_trend=True), repeat)
    rows.append(("stitch", seconds, f"max |stitched - surface| {np.max(np.abs(stitched - base.heights)):.1e} m"))
    for label, seconds, check in rows:
        print(f"{label:<42}{seconds * 1e3:>10.1f}{seconds / floor:>9.1f}   {check}")


if __name__ == "__main__":
    main()
