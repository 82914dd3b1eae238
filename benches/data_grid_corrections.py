"""Can the data grid's levels be corrected cheaply instead of solved finer (issue 39)? Per pavement
and sampling, on the segments of one synthetic run: the worst |level - level at k = 32| over every
segment, modulus, level kind and budget band of

- the model grid k = 1 (the data's own grid) to 8, with each one's solve time against k = 1's;
- Richardson on the levels from k = 1 and 2 (orders 1, 1.3 and 2) and from k = 2 and 4 (order 1):
  two solves instead of one finer one;
- a correction learnt by a pilot: the mean of (level at k = 32 - level at k) per modulus and band
  over the first half of the segments, added to the second half's levels at k (the pilot's
  segments stand for the run; the error is the second half's);
- where the data grid's error comes from: the converged (k = 32) envelope read at the readings only
  and its pressure averaged over each reading's interval, their levels on the data's grid
  ("representation"), against the k = 1 solve on that same grid ("solve").

    .venv/bin/python benches/data_grid_corrections.py                     # 4 pavements, 0.5 and 1 mm
    .venv/bin/python benches/data_grid_corrections.py --segments 20 --dx 0.5

A benchmark: it prints, it never fails on a number. Solves at tol 1e-9, numpy's linear interpolation
(the job's interpolant), the job's moduli, pressure and 0.5 m segments.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import roadtex
from roadtex.archive import ProcessingOptions
from roadtex.budget.noise import budget_bands
from roadtex.models.grid import refine_periodic
from roadtex.spectra.bands import REFERENCE_PRESSURE

TRUTH = 32
LADDER = (1, 2, 3, 4, 6, 8)


def levels(envelope: np.ndarray, pressure: np.ndarray, dx: float, bands: np.ndarray) -> np.ndarray:
    """(2, rows, budget bands) dB: enveloped and pressure levels of (segments, moduli, points) arrays."""
    rows = envelope.shape[0] * envelope.shape[1]
    out = []
    for values, reference in ((envelope, None), (pressure, REFERENCE_PRESSURE)):
        kwargs = {} if reference is None else {"reference": reference}
        table = roadtex.band_levels(values.reshape(rows, -1), dx, periodic=True, **kwargs)
        numbers = list(table.bands["band"].to_list())
        out.append(table.levels[:, [numbers.index(b) for b in bands]])
    return np.stack(out)


def study(kind: str, dx: float, n_segments: int, options: ProcessingOptions) -> None:
    profile = roadtex.synthetic_pavement(kind, length=n_segments * options.segment_length + 0.01, dx=dx, seed=3)
    cleaned, _ = roadtex.profiles.conditioning.clean(profile, warn=False)
    segments = cleaned.finished(dx=dx).segments(options.segment_length)
    heights = segments.heights[:n_segments]
    bands = budget_bands(segments.dx, options.segment_length)["band"].to_numpy()
    moduli = np.asarray(options.youngs_moduli)
    solved: dict[int, tuple[np.ndarray, float, object]] = {}
    for k in (*LADDER, TRUTH):
        model = refine_periodic(heights, k, "linear")
        started = time.perf_counter()
        batch = roadtex.contact_many(model, segments.dx / k, moduli, options.mean_pressure, tol=1e-9,
                                     warm_start=True, raise_on_nonconvergence=False)
        seconds = time.perf_counter() - started
        solved[k] = (levels(batch.envelope, batch.pressure, segments.dx / k, bands), seconds, batch)
    truth = solved[TRUTH][0]

    def worst(estimate: np.ndarray, against: np.ndarray = truth) -> float:
        return float(np.nanmax(np.abs(estimate - against)))

    print(f"\n{kind} at {dx * 1e3:g} mm: {heights.shape[0]} segments x {moduli.size} moduli, "
          f"{bands.size} budget bands; k = 32 took {solved[TRUTH][1]:.2f} s")
    print("  k:                " + "  ".join(f"{k:>6d}" for k in LADDER))
    print("  worst error (dB): " + "  ".join(f"{worst(solved[k][0]):6.3f}" for k in LADDER))
    print("  time / k = 1's:   " + "  ".join(f"{solved[k][1] / solved[1][1]:6.1f}" for k in LADDER))
    one, two, four = solved[1][0], solved[2][0], solved[4][0]
    for order in (1.0, 1.3, 2.0):
        print(f"  Richardson k = 1, 2, order {order:g}: {worst(two + (two - one) / (2 ** order - 1)):.3f} dB "
              f"(cost {(solved[1][1] + solved[2][1]) / solved[1][1]:.1f} x k = 1)")
    print(f"  Richardson k = 2, 4, order 1: {worst(four + (four - two)):.3f} dB "
          f"(cost {(solved[2][1] + solved[4][1]) / solved[1][1]:.1f} x k = 1)")
    half = heights.shape[0] // 2 * moduli.size   # rows are (segment, modulus), segment-major
    for k in (1, 2, 3, 4):
        level = solved[k][0]
        shape = (2, -1, moduli.size, bands.size)
        bias = (truth - level)[:, :half].reshape(shape).mean(axis=1, keepdims=True)
        corrected = (level[:, half:].reshape(shape) + bias).reshape(2, -1, bands.size)
        print(f"  k = {k} + a pilot's mean correction (first half -> second half): "
              f"{worst(corrected, truth[:, half:]):.3f} dB (uncorrected {worst(level[:, half:], truth[:, half:]):.3f})")
    fine = solved[TRUTH][2]
    cells = np.roll(fine.pressure, TRUTH // 2, axis=-1)
    cells = cells.reshape(*cells.shape[:-1], -1, TRUTH).mean(axis=-1)
    represented = levels(fine.envelope[..., ::TRUTH], cells, segments.dx, bands)
    print(f"  where k = 1's error comes from: the converged answer on the data's grid {worst(represented):.3f} dB "
          f"off (representation); k = 1 against it {worst(one, represented):.3f} dB (solve)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--segments", type=int, default=20, help="0.5 m segments per pavement")
    parser.add_argument("--dx", type=float, nargs="+", default=[0.5, 1.0], help="samplings (mm)")
    parser.add_argument("--kinds", nargs="+", default=["dense_asphalt", "porous_asphalt", "cement_concrete",
                                                       "surface_dressing"])
    args = parser.parse_args()
    options = ProcessingOptions()
    warnings.simplefilter("ignore")
    for dx in args.dx:
        for kind in args.kinds:
            study(kind, dx * 1e-3, args.segments, options)


if __name__ == "__main__":
    main()
