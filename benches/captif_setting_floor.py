"""What the CAPTIF files allow the error budget (issue 15): every level's difference from the
full-resolution solve, for FFT-friendly point counts and two resamplers, with no pilot in between.

For each CAPTIF file (0.0375 mm, 0.5 m segments of N = 13,337 points, a prime; E = 1, 2, 5, 10 MPa,
P = 0.2 MPa): the solve at the file's own grid (tol 1e-10) is the reference; each candidate is the
run resampled to segment_length / N points, for 5-smooth N, by interval averaging (the job's
resampler, "avg") or by a band-limited polyphase filter (scipy.signal.resample_poly, "bl"), solved
at tol 1e-10 (and a few at 1e-4). Printed: solve time and ratio to the reference's, iterations, and
the worst |level difference| (dB) over segments and moduli in the error budget's bands
(texture, enveloped, pressure; then enveloped/pressure per band, 40 mm to 2.5 mm).

It shows the oracle's best case: the cheapest setting within 0.2 dB of the full-resolution job,
chosen with the answer known. A benchmark: it prints, it never fails on a number.

    .venv/bin/python benches/captif_setting_floor.py [--data ../shared/data/captif-slp]
"""

from __future__ import annotations

import argparse
import time
import warnings
from fractions import Fraction
from pathlib import Path

import numpy as np
from scipy import signal

import roadtex
from roadtex.budget.noise import in_budget
from roadtex.spectra.bands import REFERENCE_PRESSURE
from roadtex.spectra.levels import band_levels

MODULI = (1e6, 2e6, 5e6, 10e6)
PRESSURE, SEGMENT = 2e5, 0.5
CANDIDATES = [(n, how, 1e-10) for n in (13500, 10000, 8000, 6750, 5000, 4000, 3375) for how in ("avg", "bl")]
CANDIDATES += [(None, "file", 1e-4), (13500, "avg", 1e-4), (10000, "avg", 1e-4), (8000, "avg", 1e-4)]


def levels(heights: np.ndarray, dx: float, tol: float) -> tuple[list, float, float]:
    started = time.perf_counter()
    batch = roadtex.contact_many(heights, dx, MODULI, PRESSURE, tol=tol, warm_start=True)
    seconds = time.perf_counter() - started
    rows = heights.shape[0] * len(MODULI)
    kinds = [band_levels(np.repeat(heights, len(MODULI), axis=0), dx, kind="third_octave", periodic=True),
             band_levels(batch.envelope.reshape(rows, -1), dx, kind="third_octave", periodic=True),
             band_levels(batch.pressure.reshape(rows, -1), dx, kind="third_octave", periodic=True,
                         reference=REFERENCE_PRESSURE)]
    return kinds, seconds, float(np.mean(batch.iterations))


def resampled(base: roadtex.Profile, points: int | None, how: str) -> tuple[np.ndarray, float]:
    if points is None:
        return base.heights, base.dx
    if how == "avg":
        profile = base.resample(SEGMENT / points).fill_dropouts()
        return profile.heights, profile.dx
    ratio = Fraction(points * base.dx / SEGMENT).limit_denominator(100_000)
    heights = signal.resample_poly(base.heights, ratio.numerator, ratio.denominator, padtype="line")
    return heights, base.dx * ratio.denominator / ratio.numerator


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    here = Path(__file__).resolve().parents[1]
    parser.add_argument("--data", type=Path, default=here.parent / "shared" / "data" / "captif-slp")
    args = parser.parse_args()
    warnings.simplefilter("ignore", roadtex.errors.RoadtexWarning)
    for path in sorted(args.data.glob("*.dat")):
        base = roadtex.read_profile(path).conditioned(spike_alpha=3.0, detrend=None)
        reference, ref_seconds, _ = levels(base.segments(SEGMENT).heights, base.dx, 1e-10)
        bands = reference[1].bands
        budget = in_budget(bands["band"].to_numpy(), base.dx, SEGMENT, "third_octave") & bands["reported"].to_numpy()
        print(f"# {path.name}: reference N = {int(round(SEGMENT / base.dx))}, {ref_seconds:.2f} s")
        for points, how, tol in CANDIDATES:
            heights, dx = resampled(base, points, how)
            kinds, seconds, iterations = levels(roadtex.Profile.from_heights(heights, dx).segments(SEGMENT).heights, dx, tol)
            worst = []
            for mine, ref in zip(kinds, reference):
                width = min(mine.levels.shape[1], ref.levels.shape[1])
                worst.append(np.abs(mine.levels[:, :width] - ref.levels[:, :width])[:, budget[:width]].max(axis=0))
            per_band = np.round(np.maximum(worst[1], worst[2]), 2)
            print(f"N {points or 'file'} {how} tol {tol:g}: {seconds:.2f} s ({ref_seconds / seconds:.1f}x), "
                  f"{iterations:.1f} it; worst texture {worst[0].max():.3f}, enveloped {worst[1].max():.3f}, "
                  f"pressure {worst[2].max():.3f} dB; per band {per_band.tolist()}", flush=True)


if __name__ == "__main__":
    main()
