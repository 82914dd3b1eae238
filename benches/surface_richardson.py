"""Richardson on the levels of 1 mm surfaces: are levels extrapolated from two model grids within
the 0.2 dB budget of a much finer reference, and is their own stated error honest (issue 40)?

    .venv/bin/python benches/surface_richardson.py [--seeds 5] [--width 0.008] [--reference 16]

Synthetic surfaces at 1 mm (the demo's three pavements; 0.128 m tiles, the demo's moduli 1, 2, 5,
10 MPa, P = 0.2 MPa, tol 1e-10) are joined bilinearly and solved on model grids k = 2, 4, 8 times
finer each way and on the reference k (``--reference``, 16 by default); levels (enveloped and
pressure, dB) along 4 data rows as ``benches/surface_model_grid.py`` takes them, in the budget bands.

Per case, the worst difference from the reference (dB, over rows, moduli, levels and budget bands):
  plain k      the levels at k alone (what the job reports today).
  R(k/2, k)    Richardson on the levels: L(k) + (L(k) - L(k/2)) / (r - 1), with r the shrink per
               halving. ``r=3``: the rate measured on these surfaces (2.7 to 3.3 per halving,
               roadtex.budget.areal.TAIL_FACTOR_MIN's note); ``r=m``: r measured from the three
               rungs (k/4, k/2, k) as the median over levels and bands, clipped to [2, 4].
  now          the pilot's statement of the plain k today (roadtex.budget.areal: tail_factor x
               |L(k) - L(k/2)|, the factor from the rungs' shrink, in [1, 2]): worst stated, and the
               minimum and median over levels and bands of stated / actual.
  stated       the extrapolation's own error as the pilot would state it: |R(k/2, k) - R(k/4, k/2)|
               (how much the extrapolated answer still moves), per level and band; stated/actual is
               per (level, band), each the worst over rows and moduli as the job states it: its minimum
               (below 1: understated) and median.
Time: the solve seconds of each rung relative to k = 1 (one thread). A benchmark: prints, never fails.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from roadtex.budget.areal import tail_factor
from roadtex.budget.study import difference
from surface_model_grid import areal as model_grid_areal  # noqa: E402 - benches/ is the script's folder
from surface_model_grid import bench_case  # noqa: E402

KINDS = ("cement_concrete", "dense_asphalt", "porous_asphalt")


def areal(tile: np.ndarray, rows: np.ndarray, shift: np.ndarray, k: int, bands: np.ndarray) -> tuple[np.ndarray, float]:
    """Levels (2, rows x moduli, bands) along data ``rows`` of ``tile`` solved k times finer each way
    (surface_model_grid.py's solve, the same case: 1 mm, E = 1 to 10 MPa, P = 0.2 MPa, tol 1e-10)."""
    return model_grid_areal(tile, rows, shift, k, k, bands)


def extrapolate(coarse: np.ndarray, fine: np.ndarray, r: float | np.ndarray) -> np.ndarray:
    """Richardson on levels: fine + (fine - coarse) / (r - 1); -inf where either is (no power)."""
    with np.errstate(invalid="ignore"):
        out = fine + (fine - coarse) / (np.asarray(r) - 1.0)
    return np.where(np.isfinite(fine) & np.isfinite(coarse), out, fine)


def measured_rate(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    """The median shrink per halving |a - b| / |b - c| over finite entries (rungs k/4, k/2, k), in [2, 4]."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = difference(a, b) / difference(b, c)
    ratios = ratios[np.isfinite(ratios) & (ratios > 0)]
    return float(np.clip(np.median(ratios), 2.0, 4.0)) if ratios.size else 3.0


def worst(values: np.ndarray, budget: np.ndarray) -> float:
    finite = values[..., budget]
    finite = finite[np.isfinite(finite)]
    return float(finite.max()) if finite.size else float("nan")


def band_ratio(stated: np.ndarray, actual: np.ndarray, budget: np.ndarray) -> np.ndarray:
    """Stated over actual per (level, budget band), each the worst over rows and moduli (the job
    states one error per band, any row), where the actual error exceeds 0.02 dB (not noise)."""
    with np.errstate(invalid="ignore"):
        stated_band = np.nanmax(np.where(np.isfinite(stated), stated, np.nan), axis=1)[:, budget]
        actual_band = np.nanmax(np.where(np.isfinite(actual), actual, np.nan), axis=1)[:, budget]
    keep = np.isfinite(stated_band) & np.isfinite(actual_band) & (actual_band > 0.02)
    return stated_band[keep] / actual_band[keep]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", default="5")
    parser.add_argument("--kinds", default=",".join(KINDS))
    parser.add_argument("--width", type=float, default=0.008)
    parser.add_argument("--reference", type=int, default=16)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    rungs = (1, 2, 4, 8)
    summary: list[dict[str, float | str]] = []
    for kind in args.kinds.split(","):
        for seed in (int(s) for s in args.seeds.split(",")):
            tile, rows, _, shift, bands, budget = bench_case(kind, args.width, seed)
            reference, ref_seconds = areal(tile, rows, shift, args.reference, bands)
            levels, seconds = {}, {}
            for k in rungs:
                levels[k], seconds[k] = areal(tile, rows, shift, k, bands)
            print(f"{kind} seed {seed}, {tile.shape[0]} x {tile.shape[1]} points; reference k = {args.reference} "
                  f"({ref_seconds / seconds[1]:.0f} x k=1); rungs' time x k=1: "
                  + ", ".join(f"{k}: {seconds[k] / seconds[1]:.1f}" for k in rungs), flush=True)
            for k in (4, 8):
                plain = worst(difference(levels[k], reference), budget)
                r = measured_rate(levels[k // 4], levels[k // 2], levels[k])
                fixed = extrapolate(levels[k // 2], levels[k], 3.0)
                measured = extrapolate(levels[k // 2], levels[k], r)
                before = extrapolate(levels[k // 4], levels[k // 2], 3.0)
                actual = difference(fixed, reference)
                stated = difference(fixed, before)
                ratio = band_ratio(stated, actual, budget)
                step = difference(levels[k], levels[k // 2])
                now = tail_factor(step, difference(levels[k // 2], levels[k // 4])) * step
                now_ratio = band_ratio(now, difference(levels[k], reference), budget)
                row = {"case": f"{kind} {seed}", "k": k, "plain": plain, "r3": worst(actual, budget),
                       "rm": worst(difference(measured, reference), budget), "r": r, "stated": worst(stated, budget),
                       "now": worst(now, budget), "now_min": float(now_ratio.min()) if now_ratio.size else float("nan"),
                       "now_median": float(np.median(now_ratio)) if now_ratio.size else float("nan"),
                       "min_ratio": float(ratio.min()) if ratio.size else float("nan"),
                       "median_ratio": float(np.median(ratio)) if ratio.size else float("nan")}
                summary.append(row)
                print(f"  k {k}: plain {plain:6.3f} dB, now stated {row['now']:6.3f} (stated/actual min "
                      f"{row['now_min']:.2f} median {row['now_median']:.2f})\n         R(k/2, k) r=3 {row['r3']:6.3f}, r=m ({r:.2f}) "
                      f"{row['rm']:6.3f} dB"
                      f" | stated {row['stated']:6.3f} dB, stated/actual min {row['min_ratio']:.2f} median "
                      f"{row['median_ratio']:.2f}", flush=True)
    print("# worst over every case (dB, budget bands):")
    for k in (4, 8):
        rows_k = [s for s in summary if s["k"] == k]
        print(f"  k {k}: plain {max(s['plain'] for s in rows_k):.3f}, R r=3 {max(s['r3'] for s in rows_k):.3f}, "
              f"R r=m {max(s['rm'] for s in rows_k):.3f}, stated {max(s['stated'] for s in rows_k):.3f}, "
              f"stated/actual min {min(s['min_ratio'] for s in rows_k):.2f}; now stated/actual min "
              f"{min(s['now_min'] for s in rows_k):.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
