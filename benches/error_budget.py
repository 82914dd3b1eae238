"""Error budget (issue 15): the pilot's choice against the full-resolution job on the CAPTIF files.

Run from the project root:

    .venv/bin/python benches/error_budget.py                 # the three CAPTIF files, a few minutes
    .venv/bin/python benches/error_budget.py --budget 0.1
    .venv/bin/python benches/error_budget.py --no-truth      # skip the 3x finer solves
    .venv/bin/python benches/error_budget.py --json rows.json

The CAPTIF files (0.0375 mm sampling, about 1.9 m each) are read from ../shared/data/captif-slp
beside the repository, or from --data. This is a benchmark, not a test: it prints tables and never
fails on a number.

What is measured, per file, with the job's defaults (ProcessingOptions: moduli 1, 2, 5 and
10 MPa, P = 0.2 MPa, 0.5 m segments, third octaves, no spike removal):

  full      every segment solved at the file's dx and tol 1e-10 (the full-resolution job; the
            segments of 13,337 points, a prime, so every FFT is a slow one);
  pilot     roadtex.choose_setting on the run (default: 3 pilot segments), its wall time;
  chosen    every segment solved at the pilot's (dx, tol);
  truth     every segment at dx / 3 (each sample repeated 3 times), tol 1e-10: the converged
            answer the stated errors are about (--no-truth skips it).

Columns: time per metre of segments (solve only, best of --repeats), the run speed-up full/chosen,
the job speed-up full / (pilot + chosen) for the run alone and with one pilot for the three files
(a group of runs of the same device and pavement), the stated worst error in the budget bands and
the actual worst |level - reference| over every segment, modulus and level kind (texture,
enveloped, pressure), against the full-resolution job and against the truth. Then, per band,
stated against actual. Timings on a loaded machine are noisy: ratios from the same run matter, and
the header prints the load average.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

import roadtex
from roadtex.archive import ProcessingOptions
from roadtex.spectra.bands import REFERENCE_PRESSURE

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "captif-slp"
FILES = ("20211011_aylesbury_dec_station_0.dat", "20211011_aylesbury_dec_station_1.dat",
         "20211011_aylesbury_dec_station_10.dat")


def solve(heights: np.ndarray, dx: float, moduli: np.ndarray, pressure: float, tol: float,
          repeats: int) -> tuple[float, object]:
    best, batch = np.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        batch = roadtex.contact_many(heights, dx, moduli, pressure, tol=tol, warm_start=True,
                                     raise_on_nonconvergence=False)
        best = min(best, time.perf_counter() - start)
    return best, batch


def levels(heights: np.ndarray, dx: float, batch: object, n_moduli: int) -> tuple[list[int], np.ndarray]:
    """Reported band numbers and (3 kinds, rows, bands) levels; texture repeated per modulus."""
    rows = heights.shape[0] * n_moduli
    texture = roadtex.band_levels(heights, dx, periodic=True)
    env = roadtex.band_levels(batch.envelope.reshape(rows, -1), dx, periodic=True)  # type: ignore[attr-defined]
    pr = roadtex.band_levels(batch.pressure.reshape(rows, -1), dx, periodic=True,  # type: ignore[attr-defined]
                             reference=REFERENCE_PRESSURE)
    return (texture.bands["band"].to_list(),
            np.stack([np.repeat(texture.levels, n_moduli, axis=0), env.levels, pr.levels]))


def worst(bands_a: list[int], a: np.ndarray, bands_b: list[int], b: np.ndarray, wanted: list[int]) -> dict[int, float]:
    out = {}
    for band in wanted:
        if band in bands_a and band in bands_b:
            d = np.abs(a[:, :, bands_a.index(band)] - b[:, :, bands_b.index(band)])
            out[band] = float(np.nanmax(d))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--budget", type=float, default=roadtex.budget.DEFAULT_ERROR_BUDGET_DB)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--no-truth", action="store_true")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    if not args.data.is_dir():
        sys.exit(f"no CAPTIF folder at {args.data}")
    options = ProcessingOptions()
    moduli = np.asarray(options.youngs_moduli)
    pressure, length = options.mean_pressure, options.segment_length
    print(f"roadtex {roadtex.__version__}; {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}; "
          f"E = {', '.join(f'{e / 1e6:g}' for e in moduli)} MPa, P = {pressure / 1e6:g} MPa, "
          f"segments {length} m, budget {args.budget} dB")
    profiles = [roadtex.read_profile(args.data / name) for name in FILES]
    rows, per_band = [], []
    totals = {"full": 0.0, "chosen": 0.0, "pilot": 0.0}
    for name, profile in zip(FILES, profiles):
        for include in (True, False):
            choice = roadtex.choose_setting(profile, youngs_moduli=moduli, mean_pressure=pressure,
                                            segment_length=length, budget_db=args.budget,
                                            include_reference_error=include)
            fine = profile.conditioned(spike_alpha=None).segments(length)
            metres = len(fine) * length
            t_full, b_full = solve(fine.heights, fine.dx, moduli, pressure, 1e-10, args.repeats)
            bands_full, full = levels(fine.heights, fine.dx, b_full, moduli.size)
            coarse = profile.conditioned(dx=choice.dx, spike_alpha=None).segments(length)
            t_chosen, b_chosen = solve(coarse.heights, coarse.dx, moduli, pressure, choice.tol, args.repeats)
            bands_chosen, chosen = levels(coarse.heights, coarse.dx, b_chosen, moduli.size)
            against_full = worst(bands_chosen, chosen, bands_full, full, list(choice.band_error_db))
            against_truth: dict[int, float] = {}
            if include and not args.no_truth:
                _, b3 = solve(np.repeat(fine.heights, 3, axis=1), fine.dx / 3, moduli, pressure, 1e-10, 1)
                bands3, truth = levels(np.repeat(fine.heights, 3, axis=1), fine.dx / 3, b3, moduli.size)
                assert bands3 == bands_full  # the same candidate bands: texture truth is the file's own
                truth[0] = full[0]
                against_truth = worst(bands_chosen, chosen, bands3, truth, list(choice.band_error_db))
            budget = list(choice.budget_bands)
            row = {
                "file": name, "include_reference_error": include, "dx_mm": choice.dx * 1e3, "points": choice.points,
                "tol": choice.tol, "stated_worst_db": choice.worst_error_db, "within_budget": choice.within_budget,
                "actual_worst_vs_full_db": max(against_full[b] for b in budget),
                "actual_worst_vs_truth_db": max((against_truth[b] for b in budget if b in against_truth), default=float("nan")),
                "full_s_per_m": t_full / metres, "chosen_s_per_m": t_chosen / metres,
                "run_speedup": t_full / t_chosen, "pilot_s": choice.pilot_seconds,
                "job_speedup_per_run": t_full / (t_chosen + choice.pilot_seconds),
            }
            rows.append(row)
            if include:
                totals["full"] += t_full
                totals["chosen"] += t_chosen
                for band in sorted(choice.band_error_db):
                    per_band.append({"file": name, "band": band, "budget": band in budget,
                                     "stated_db": choice.band_error_db[band], "vs_full_db": against_full.get(band),
                                     "vs_truth_db": against_truth.get(band)})
    start = time.perf_counter()
    group = roadtex.choose_setting(profiles, youngs_moduli=moduli, mean_pressure=pressure, segment_length=length,
                                   budget_db=args.budget)
    totals["pilot"] = time.perf_counter() - start

    print("\nper file (stated and actual: worst over the budget bands, every segment, modulus and level kind)")
    header = (f"{'file':<40}{'ref err':>8}{'dx mm':>9}{'N':>7}{'tol':>8}{'stated':>8}{'vs full':>8}{'vs truth':>9}"
              f"{'full s/m':>10}{'chosen s/m':>11}{'run x':>7}{'pilot s':>8}{'job x':>7}")
    print(header)
    for r in rows:
        print(f"{r['file']:<40}{'yes' if r['include_reference_error'] else 'no':>8}{r['dx_mm']:>9.4f}{r['points']:>7}"
              f"{r['tol']:>8.0e}{r['stated_worst_db']:>8.3f}{r['actual_worst_vs_full_db']:>8.3f}"
              f"{r['actual_worst_vs_truth_db']:>9.3f}{r['full_s_per_m']:>10.3f}{r['chosen_s_per_m']:>11.3f}"
              f"{r['run_speedup']:>7.2f}{r['pilot_s']:>8.2f}{r['job_speedup_per_run']:>7.2f}")
    print(f"\none pilot for the three files (a group): dx {group.dx * 1e3:.4f} mm (N = {group.points}), tol "
          f"{group.tol:.0e}, stated worst {group.worst_error_db:.3f} dB, pilot {totals['pilot']:.2f} s; "
          f"the three runs: full {totals['full']:.2f} s, at each file's own choice {totals['chosen']:.2f} s")
    print("\nper band (reference error included): stated >= actual?  (* = budget band)")
    print(f"{'file':<40}{'band':>5}{'stated':>8}{'vs full':>9}{'vs truth':>9}")
    for r in per_band:
        truth = r["vs_truth_db"]
        print(f"{r['file']:<40}{r['band']:>4}{'*' if r['budget'] else ' '}{r['stated_db']:>8.3f}"
              f"{(r['vs_full_db'] if r['vs_full_db'] is not None else float('nan')):>9.3f}"
              f"{(truth if truth is not None else float('nan')):>9.3f}")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "per_band": per_band, "totals": totals}, indent=1))


if __name__ == "__main__":
    main()
