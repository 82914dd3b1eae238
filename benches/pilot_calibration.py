"""The data behind the line pilot's error rule (issue 39): every segment of a few runs solved on every
candidate model grid, so that any pilot (its segment count, its spread factor, its Richardson rule)
can be replayed against the actual worst error over the whole run (k = 32, tol 1e-10).

    .venv/bin/python benches/pilot_calibration.py --save /tmp/calibration.npz   # solve (minutes)
    .venv/bin/python benches/pilot_calibration.py --load /tmp/calibration.npz   # replay only

Archives: one 20 m run of each synthetic pavement at 1 mm (each its own pilot group, as in the job)
and the three CAPTIF files averaged to 1 mm (``Profile.resample(1e-3)``; one group) when
ROADTEX_CAPTIF_DIR (or ../shared/data/captif-slp) holds them. For each group, m pilot segments
(spread evenly, as :func:`roadtex.budget.study.build_pilot` picks them) give the estimate of
:func:`roadtex.budget.study.stated_errors` per band and candidate k; it is printed against the actual
worst |L(k) - L(32)| over every segment and modulus of the group: stated / actual (median, min) and
the k chosen against the smallest k within the 0.2 dB budget. A benchmark: it prints, never fails.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

import roadtex
from roadtex.budget.estimate import PILOT_SPREAD_FACTOR, run_extreme
from roadtex.budget.noise import DEFAULT_ERROR_BUDGET_DB, in_budget
from roadtex.budget.study import REFERENCE_TOL, cleaned_profiles, contact_levels, difference, segments_of, stated_errors
from roadtex.models.grid import refine_periodic

LADDER = (1, 2, 3, 4, 6, 8, 12, 16, 32)
MODULI = np.array([1e6, 2e6, 5e6, 1e7])
PRESSURE = 2e5
SEGMENT = 0.5


def captif_dir() -> Path | None:
    here = Path(os.environ.get("ROADTEX_CAPTIF_DIR", Path(__file__).resolve().parents[1] / "../shared/data/captif-slp"))
    return here if here.is_dir() and any(here.glob("*.dat")) else None


def groups(length: float) -> dict[str, list[roadtex.Profile]]:
    out = {kind: [roadtex.synthetic_pavement(kind, length=length, dx=1e-3, seed=7)]
           for kind in ("dense_asphalt", "porous_asphalt", "cement_concrete", "surface_dressing")}
    folder = captif_dir()
    if folder is not None:
        out["captif @ 1 mm"] = [roadtex.read_profile(p).resample(1e-3) for p in sorted(folder.glob("*.dat"))]
    return out


def solve_all(profiles: list[roadtex.Profile]) -> tuple[np.ndarray, np.ndarray, dict[int, np.ndarray]]:
    """Band numbers, budget mask and k -> levels (2, rows, bands) of every segment (rows segment-major)."""
    heights, _, dx = segments_of(cleaned_profiles(profiles, None), None, SEGMENT)
    bands = roadtex.band_levels(heights[:1], dx, periodic=True).bands
    numbers = bands.filter(bands["reported"])["band"].to_numpy()
    levels = {}
    for k in LADDER:
        batch = roadtex.contact_many(refine_periodic(heights, k), dx / k, MODULI, PRESSURE, tol=REFERENCE_TOL,
                                     warm_start=True, raise_on_nonconvergence=False)
        levels[k], _ = contact_levels(batch.envelope, batch.pressure, dx / k, numbers, "third_octave")
        print(f"  k = {k:2d}: {heights.shape[0]} segments, mean iterations {batch.iterations.mean():.0f}", flush=True)
    return numbers, in_budget(numbers, dx, SEGMENT), levels


def replay(name: str, numbers: np.ndarray, budget: np.ndarray, levels: dict[int, np.ndarray], m: int,
           spread: float) -> dict:
    rows = levels[1].shape[1]
    segments = rows // MODULI.size
    picks = np.unique(np.round(np.linspace(0, segments - 1, min(m, segments))).astype(int))
    pilot_rows = (picks[:, None] * MODULI.size + np.arange(MODULI.size)).ravel()
    sequence = {k: v[:, pilot_rows] for k, v in levels.items()}
    ladder = [k for k in LADDER if k < 32]
    stated, ref_error, flags = stated_errors(sequence, ladder, budget, rows, spread_factor=spread)
    truth = levels[32]
    ratios, chosen, smallest, short = [], None, None, 0.0
    for k in sorted(stated):
        actual = difference(levels[k], truth).max(axis=1)[:, budget].max(axis=0)
        state = stated[k][budget]
        ratios.extend((state / np.maximum(actual, 1e-3)).tolist())
        short = max(short, float((actual - state).max()))
        if chosen is None and state.max() <= DEFAULT_ERROR_BUDGET_DB:
            chosen = k
        if smallest is None and actual.max() <= DEFAULT_ERROR_BUDGET_DB:
            smallest = k
    r = np.array(ratios)
    return {"name": name, "m": m, "median": float(np.median(r)), "min": float(r.min()),
            "below": int((r < 1).sum()), "short": short, "chosen": chosen, "smallest": smallest, "K": max(stated),
            "flags": sorted(set(flags[:, budget].ravel().tolist()))}


def replay_corrected(name: str, budget: np.ndarray, levels: dict[int, np.ndarray], m: int) -> None:
    """A rule not adopted (issue 39): each candidate's levels corrected by the pilot's mean difference
    from its reference per modulus and band, stated from the leave-one-out residuals (the rule's
    extreme and spread factor, plus the reference's own error), against the uncorrected rule; worst
    stated and actual over the budget bands, and stated / actual (median, least) of the corrected."""
    rows = levels[1].shape[1]
    segments = rows // MODULI.size
    picks = np.unique(np.round(np.linspace(0, segments - 1, min(m, segments))).astype(int))
    pilot_rows = (picks[:, None] * MODULI.size + np.arange(MODULI.size)).ravel()
    sequence = {k: v[:, pilot_rows] for k, v in levels.items()}
    stated, ref_error, _ = stated_errors(sequence, [k for k in LADDER if k < 32], budget, rows,
                                         spread_factor=PILOT_SPREAD_FACTOR)
    reference = max(stated)
    print(f"{name}: {picks.size} pilot segments of {segments}, reference k = {reference}")
    for k in sorted(stated):
        if k == reference:
            continue
        differences = (sequence[reference] - sequence[k]).reshape(2, picks.size, MODULI.size, -1)
        correction = differences.mean(axis=1)
        residuals = ((differences - correction[:, None]) * picks.size / max(picks.size - 1, 1)).reshape(2, -1, budget.size)
        corrected_stated = (run_extreme(residuals, np.zeros_like(residuals), rows, PILOT_SPREAD_FACTOR) + ref_error).max(axis=0)
        corrected = (levels[k].reshape(2, segments, MODULI.size, -1) + correction[:, None]).reshape(2, rows, -1)
        actual = difference(corrected, levels[32]).max(axis=1).max(axis=0)[budget]
        plain = difference(levels[k], levels[32]).max(axis=1).max(axis=0)[budget]
        ratio = corrected_stated[budget] / np.maximum(actual, 1e-3)
        print(f"  k = {k:2d}: uncorrected stated {stated[k][budget].max():.3f} actual {plain.max():.3f} | corrected "
              f"stated {corrected_stated[budget].max():.3f} actual {actual.max():.3f}, stated / actual median "
              f"{np.median(ratio):.2f} least {ratio.min():.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--length", type=float, default=20.0, help="metres per synthetic run")
    parser.add_argument("--save", default=None)
    parser.add_argument("--load", default=None)
    parser.add_argument("--spread", type=float, nargs="+", default=[2.0], help="spread factors to replay")
    parser.add_argument("--segments", type=int, nargs="+", default=[3, 6, 8, 12], help="pilot segment counts")
    parser.add_argument("--corrected", action="store_true",
                        help="also replay the corrected rule (not adopted) with the largest segment count")
    args = parser.parse_args()
    data: dict[str, tuple[np.ndarray, np.ndarray, dict[int, np.ndarray]]] = {}
    if args.load:
        stored = np.load(args.load, allow_pickle=False)
        for name in sorted({key.split("|")[0] for key in stored.files}):
            data[name] = (stored[f"{name}|numbers"], stored[f"{name}|budget"],
                          {k: stored[f"{name}|{k}"] for k in LADDER})
    else:
        for name, profiles in groups(args.length).items():
            print(name, flush=True)
            data[name] = solve_all(profiles)
        if args.save:
            np.savez(args.save, **{f"{n}|{key}": value for n, (numbers, budget, levels) in data.items()
                                   for key, value in [("numbers", numbers), ("budget", budget)]
                                   + [(str(k), v) for k, v in levels.items()]})
    for spread in args.spread:
        print(f"\nspread factor {spread:g}\ngroup                  m  K  stated/actual median   min  below 1 (most, dB)  "
              "chosen k  smallest k within budget  Richardson")
        for name, (numbers, budget, levels) in data.items():
            for m in args.segments:
                r = replay(name, numbers, budget, levels, m, spread)
                print(f"{name:<20} {m:3d} {r['K']:2d} {r['median']:12.2f} {r['min']:13.2f} {r['below']:6d} ({max(r['short'], 0.0):.3f}) "
                      f"{r['chosen']!s:>9} {r['smallest']!s:>9}          {', '.join(r['flags'])}")

    if args.corrected:
        print("\nthe pilot's mean correction (not adopted)")
        for name, (_, budget, levels) in data.items():
            replay_corrected(name, budget, levels, max(args.segments))


if __name__ == "__main__":
    main()
