"""How far the pilot's segments under-represent the rest of a run: the data behind SPREAD_FACTOR.

Run from the project root (about two minutes on 2 cores):

    .venv/bin/python benches/budget_spread.py

For 4 synthetic pavement kinds x 2 seeds (1 m at 0.02 mm, 0.1 m segments: 10 segments, E = 2.5
and 10 MPa, P = 0.2 MPa), 10 candidate dx (N = 4096 .. 500, tol 1e-4) and the budget bands
(8 mm .. 2.5 mm), the true largest |level - reference| over every row (segment x modulus) of the
enveloped and pressure levels is compared with the pilot's extrapolation from 3 evenly spread
segments (roadtex.budget.study.extreme: each band pooled with its neighbours, the larger of the
largest pilot difference and rms x sqrt(2 ln n)). Printed: quantiles of the ratio true / estimate,
bare and times 1.5, 2 and 3, and the share of cases above 1 (an under-estimate). A benchmark, not a
test: it never fails on a number.
"""

from __future__ import annotations

import numpy as np

import roadtex
from roadtex.budget.study import extreme
from roadtex.spectra.bands import REFERENCE_PRESSURE

MODULI = np.array([2.5e6, 1e7])
KINDS = ("dense_asphalt", "cement_concrete", "porous_asphalt", "surface_dressing")
POINTS = (4096, 3200, 2500, 2000, 1600, 1250, 1000, 800, 625, 500)
BANDS = list(range(20, 28))  # budget bands 21..26 and their neighbours
PILOT = 3


def contact_levels(heights: np.ndarray, dx: float, tol: float) -> tuple[list[int], np.ndarray]:
    n = heights.shape[0] * MODULI.size
    batch = roadtex.contact_many(heights, dx, MODULI, 2e5, tol=tol, warm_start=True, raise_on_nonconvergence=False)
    env = roadtex.band_levels(batch.envelope.reshape(n, -1), dx, periodic=True)
    pr = roadtex.band_levels(batch.pressure.reshape(n, -1), dx, periodic=True, reference=REFERENCE_PRESSURE)
    return env.bands["band"].to_list(), np.stack([env.levels, pr.levels])


def main() -> None:
    ratios = []
    for kind in KINDS:
        for seed in (1, 2):
            profile = roadtex.synthetic_pavement(kind, 1.0, 0.02e-3, seed=seed)
            fine = profile.conditioned(spike_alpha=None).segments(0.1)
            bands_ref, ref = contact_levels(fine.heights, fine.dx, 1e-10)
            rows = len(fine) * MODULI.size
            pilot = np.unique(np.round(np.linspace(0, len(fine) - 1, PILOT)).astype(int))
            pilot_rows = np.concatenate([np.arange(s * MODULI.size, (s + 1) * MODULI.size) for s in pilot])
            for n in POINTS:
                coarse = profile.conditioned(dx=0.1 / n, spike_alpha=None).segments(0.1)
                bands, levels = contact_levels(coarse.heights, coarse.dx, 1e-4)
                d = np.stack([np.abs(levels[:, :, bands.index(b)] - ref[:, :, bands_ref.index(b)]) for b in BANDS],
                             axis=-1).max(axis=0)  # (rows, bands): worst of the two kinds
                estimate = extreme(d[pilot_rows], rows)
                true = d.max(axis=0)
                ratios.extend((true[1:-1] / estimate[1:-1]).tolist())  # budget bands only
            print(f"{kind} seed {seed} done", flush=True)
    r = np.asarray(ratios)
    print(f"\n{r.size} cases (profile x dx x band); ratio true largest / estimate")
    print(f"{'factor':>7}{'50%':>7}{'90%':>7}{'95%':>7}{'99%':>7}{'max':>7}{'share > 1':>11}")
    for factor in (1.0, 1.5, 2.0, 3.0):
        q = np.quantile(r / factor, [0.5, 0.9, 0.95, 0.99, 1.0])
        print(f"{factor:>7.1f}" + "".join(f"{v:>7.2f}" for v in q) + f"{np.mean(r / factor > 1):>11.3f}")


if __name__ == "__main__":
    main()
