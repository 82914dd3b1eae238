"""Band levels by the DFT method against the filter method (ISO 13473-4:2024), band by band.

- the three real CAPTIF profiles (conditioned to 0.1 mm, about 1.8 m each), analysed as measured
  profiles (periodic=False: DFT with linear detrend and Hann window; filters with linear detrend and
  settling discarded);
- long synthetic profiles (20 m at 0.25 mm) of the four synthetic pavements, the same way;
- the same synthetic profiles cut into 0.5 m segments analysed as periodic signals (as the bulk job
  analyses segments and their envelopes), energy-averaged over the segments;
- the time of both methods on 2,000 segments of 4,096 points, measured in the same run.

Prints markdown tables of filter minus DFT (dB) per band, reported bands only.

    .venv/bin/python benches/band_methods.py [--captif DIR]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import roadtex
from roadtex.profiles.trend import remove_end_lines

CAPTIF = Path(__file__).resolve().parents[2] / "shared" / "data" / "captif-slp"
KINDS = ("dense_asphalt", "porous_asphalt", "cement_concrete", "surface_dressing")


def mean_levels(rows: np.ndarray, dx: float, method: str, periodic: bool) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Energy-mean level per band over rows, and the reported flags."""
    result = roadtex.band_levels(rows, dx, method=method, periodic=periodic)
    with np.errstate(divide="ignore", invalid="ignore"):
        level = 10 * np.log10(np.mean(result.mean_square, axis=0) / 1e-12)
    return level, result.bands["reported"].to_numpy(), result.bands["label"].to_list()


def difference(rows: np.ndarray, dx: float, periodic: bool) -> dict[str, float]:
    dft, ok_dft, labels = mean_levels(rows, dx, "dft", periodic)
    filt, ok_filter, _ = mean_levels(rows, dx, "filter", periodic)
    return {label: float(f - d) for label, f, d, a, b in zip(labels, filt, dft, ok_dft, ok_filter) if a and b}


def table(columns: dict[str, dict[str, float]]) -> str:
    labels = [str(x) for x in roadtex.band_table(1e-4, 1.0)["label"].to_list()]
    names = list(columns)
    lines = ["| band (mm) | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for label in labels:
        cells = [f"{columns[n][label]:+.2f}" if label in columns[n] else "" for n in names]
        if any(cells):
            lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--captif", type=Path, default=CAPTIF)
    args = parser.parse_args()

    measured: dict[str, dict[str, float]] = {}
    for path in sorted(args.captif.glob("*.dat")):
        profile = roadtex.read_profile(path).conditioned(dx=0.1e-3)
        name = "CAPTIF " + path.stem.rsplit("_", 1)[-1]
        measured[name] = difference(np.asarray(profile.heights)[None, :], profile.dx, periodic=False)
    dx = 0.25e-3
    segmented: dict[str, dict[str, float]] = {}
    for kind in KINDS:
        z = np.asarray(roadtex.synthetic_pavement(kind, 20.0, dx, seed=1).heights)
        measured[kind + " 20 m"] = difference(z[None, :], dx, periodic=False)
        points = int(round(0.5 / dx))
        segments, _ = remove_end_lines(z[: z.size // points * points].reshape(-1, points))  # as the job cuts them
        segmented[kind + " 0.5 m periodic"] = difference(segments, dx, periodic=True)
    print("Filter minus DFT (dB), measured profiles (periodic=False):\n")
    print(table(measured))
    print("\nFilter minus DFT (dB), 0.5 m segments analysed as periodic, energy mean over 40 segments:\n")
    print(table(segmented))

    rng = np.random.default_rng(0)
    rows = np.cumsum(rng.standard_normal((2000, 4096)), axis=1) * 1e-6
    print("\nTime, 2,000 segments of 4,096 points at 0.05 mm (best of 2):\n")
    print("| method | periodic=False | periodic=True |\n|---|---|---|")
    for method in ("dft", "filter"):
        times = []
        for periodic in (False, True):
            best = np.inf
            for _ in range(2):
                start = time.perf_counter()
                roadtex.band_levels(rows, 5e-5, method=method, periodic=periodic)
                best = min(best, time.perf_counter() - start)
            times.append(best)
        print(f"| {method} | {times[0]:.2f} s | {times[1]:.2f} s |")


if __name__ == "__main__":
    main()
