"""Band levels for many segments: roadtex.spectra.band_levels on 10,000 segments of 4,096 points.

The segments are random texture (normal heights, 0.1 mm rms) at dx = 0.05 mm (204.8 mm each). Row 0
is a check sine of 0.1 mm amplitude with 25 whole periods (8.192 mm, in the 8 mm band), so every run
also prints a level to compare with the exact 36.99 dB. Timed, best of ``--repeats`` (wall clock;
numpy FFT by blocks of rows, then one matrix product per block for the band sums):

- third octaves of measured profiles (linear detrend, Hann window), the bulk job's "original";
- third octaves of periodic signals (no window), its "enveloped" and pressure spectra;
- octaves of measured profiles;
- third octaves from float32 input (converted to float64 inside).

Run:  .venv/bin/python benches/spectra_bench.py [--segments 10000] [--points 4096] [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from roadtex import spectra

DX = 5e-5  # m
SINE_AMPLITUDE = 1e-4  # m
SINE_PERIODS = 25  # whole periods in the segment: wavelength 8.192 mm at 4,096 points, in the 8 mm band


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--segments", type=int, default=10_000)
    parser.add_argument("--points", type=int, default=4096)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    rng = np.random.default_rng(0)
    segments = 1e-4 * rng.standard_normal((args.segments, args.points))
    segments[0] = SINE_AMPLITUDE * np.sin(2 * np.pi * SINE_PERIODS * np.arange(args.points) / args.points)
    wavelength = args.points * DX / SINE_PERIODS
    expected = 20 * np.log10(SINE_AMPLITUDE / np.sqrt(2) / spectra.REFERENCE_TEXTURE)
    megabytes = segments.nbytes / 2**20
    print(f"band_levels: {args.segments} segments x {args.points} points ({megabytes:.0f} MB float64), "
          f"dx = {DX * 1e3:g} mm, best of {args.repeats}; {os.cpu_count()} CPUs")

    cases = {
        "third octaves, measured (detrend + Hann)": dict(kind="third_octave", periodic=False),
        "third octaves, periodic (no window)": dict(kind="third_octave", periodic=True),
        "octaves, measured (detrend + Hann)": dict(kind="octave", periodic=False),
    }
    for name, options in cases.items():
        times = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            result = spectra.band_levels(segments, DX, **options)
            times.append(time.perf_counter() - start)
        best = min(times)
        bands = result.bands
        column = int(np.flatnonzero((bands["lower_wavelength"] <= wavelength).to_numpy()
                                    & (bands["upper_wavelength"] > wavelength).to_numpy())[0])
        label = bands["label"][column]
        print(f"  {name:42s} {best:6.2f} s  ({args.segments / best:,.0f} segments/s, "
              f"{bands['reported'].sum()} of {bands.height} bands reported); "
              f"check: sine {wavelength * 1e3:.3f} mm in the {label} mm band = {result.levels[0, column]:.4f} dB "
              f"(exact {expected:.4f})")
    single = segments.astype(np.float32)
    times = []
    for _ in range(args.repeats):
        start = time.perf_counter()
        spectra.band_levels(single, DX)
        times.append(time.perf_counter() - start)
    print(f"  {'third octaves, measured, float32 input':42s} {min(times):6.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
