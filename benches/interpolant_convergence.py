"""How fast each road between readings converges with the model grid (issue 39): the linear road
against the monotone cubic (pchip), the job's default since 0.5.0.

    .venv/bin/python benches/interpolant_convergence.py [--segments 20] [--samplings 1,0.5]

Per synthetic pavement (dense and porous asphalt, cement concrete, surface dressing) and sampling
(mm), ``--segments`` 0.5 m segments of one run, the four moduli of the job (1, 2, 5, 10 MPa, P =
0.2 MPa), each road refined k times and solved at tol 1e-9; printed per k: the worst |level - level
at k = 32 of the same road| (dB) over segments, moduli and the budget bands, of the enveloped and
of the pressure levels, and the smallest k of the ladder within the 0.2 dB budget. A benchmark: it
prints, it never fails on a number.

Measured 2026-11-27 (20 segments; worst of enveloped and pressure, dB; k = 2, 3, 4, 6, 8):

| pavement @ mm | linear | pchip |
|---|---|---|
| dense asphalt @ 1 | 1.10 0.76 0.53 0.31 0.21 | 0.97 0.41 0.24 0.11 0.04 |
| porous asphalt @ 1 | 1.35 0.64 0.39 0.19 0.13 | 0.43 0.21 0.15 0.06 0.04 |
| cement concrete @ 1 | 1.26 0.75 0.44 0.26 0.12 | 0.62 0.31 0.20 0.14 0.06 |
| surface dressing @ 1 | 1.31 0.61 0.35 0.16 0.09 | 0.43 0.20 0.12 0.06 0.03 |
| dense asphalt @ 0.5 | 0.48 0.32 0.22 0.12 0.08 | 0.27 0.13 0.07 0.04 0.01 |
| porous asphalt @ 0.5 | 0.35 0.19 0.10 0.06 0.04 | 0.21 0.08 0.04 0.02 0.01 |
| cement concrete @ 0.5 | 2.04 1.26 0.81 0.32 0.16 | 0.81 0.32 0.15 0.11 0.03 |
| surface dressing @ 0.5 | 0.37 0.17 0.09 0.05 0.02 | 0.18 0.07 0.04 0.03 0.01 |

The pchip road reaches a given error at about half the k of the linear road: the linear road has a
corner at every reading, where the rubber rests, and the pressure on a corner is singular.
"""

from __future__ import annotations

import argparse
import tempfile
import warnings
from pathlib import Path

import numpy as np
import polars as pl

import roadtex
from roadtex.budget.noise import DEFAULT_ERROR_BUDGET_DB, budget_bands
from roadtex.demo import write_synthetic_archive
from roadtex.models.grid import refine_periodic
from roadtex.spectra.bands import REFERENCE_PRESSURE

KINDS = ("dense_asphalt", "porous_asphalt", "cement_concrete", "surface_dressing")
MODULI = np.array([1e6, 2e6, 5e6, 1e7])
PRESSURE = 2e5
SEGMENT = 0.5
LADDER = (2, 3, 4, 6, 8)
TRUTH = 32


def segments(kind: str, dx: float, count: int, work: Path) -> np.ndarray:
    """``count`` conditioned 0.5 m segments of one synthetic run, as the job cuts them."""
    manifest = write_synthetic_archive(work / f"{kind}-{dx:g}", kinds=(kind,), runs_per_kind=1,
                                       run_length=count * SEGMENT, dx=dx)
    profile = roadtex.read_profile(Path(manifest).parent / pl.read_csv(manifest)["path"][0])
    cleaned, _ = roadtex.profiles.conditioning.clean(profile, warn=False)
    return cleaned.finished(dx=dx).segments(SEGMENT).heights


def levels(heights: np.ndarray, dx: float, k: int, road: str, budget: np.ndarray) -> np.ndarray:
    """(2 kinds, rows, budget bands) levels of the segments solved on ``road`` refined k times."""
    fine = refine_periodic(heights, k, road)  # type: ignore[arg-type]
    batch = roadtex.contact_many(fine, dx / k, MODULI, PRESSURE, tol=1e-9, warm_start=True,
                                 raise_on_nonconvergence=False)
    rows = fine.shape[0] * MODULI.size
    env = roadtex.band_levels(batch.envelope.reshape(rows, -1), dx / k, periodic=True)
    pr = roadtex.band_levels(batch.pressure.reshape(rows, -1), dx / k, periodic=True, reference=REFERENCE_PRESSURE)
    keep = np.isin(np.asarray(env.bands["band"].to_list()), budget)
    return np.stack([env.levels[:, keep], pr.levels[:, keep]])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--segments", type=int, default=20)
    parser.add_argument("--samplings", default="1,0.5", help="sampling intervals (mm), comma-separated")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    work = Path(tempfile.mkdtemp(prefix="interpolants-"))
    for dx in (float(v) * 1e-3 for v in args.samplings.split(",")):
        budget = budget_bands(dx, SEGMENT)["band"].to_numpy()
        for kind in KINDS:
            heights = segments(kind, dx, args.segments, work)
            for road in ("linear", "pchip"):
                truth = levels(heights, dx, TRUTH, road, budget)
                worst = []
                for k in LADDER:
                    gap = np.abs(levels(heights, dx, k, road, budget) - truth).max(axis=(1, 2))
                    worst.append((k, float(gap[0]), float(gap[1])))
                within = next((k for k, e, p in worst if max(e, p) <= DEFAULT_ERROR_BUDGET_DB), None)
                text = "  ".join(f"k {k}: {e:.2f}/{p:.2f}" for k, e, p in worst)
                print(f"{kind} @ {dx * 1e3:g} mm, {road:6}: {text}  (enveloped/pressure dB); smallest k within "
                      f"{DEFAULT_ERROR_BUDGET_DB:g} dB: {within or f'> {LADDER[-1]}'}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
