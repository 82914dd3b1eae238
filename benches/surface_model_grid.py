"""How fine the areal model's grid must be on 1 mm surfaces, along and across the road (issue 34).

    .venv/bin/python benches/surface_model_grid.py [--seeds 5,6] [--width 0.016] [--reference 16,16]

Synthetic surfaces at 1 mm (dense asphalt, porous asphalt, cement concrete; 0.128 m tiles, the
demo's moduli 1, 2, 5, 10 MPa, P = 0.2 MPa, tol 1e-10) are joined by ``--interpolant`` (the job's
road, monotone cubics since 0.5.0; bilinear before: the figures below)
(:func:`roadtex.models.grid.refine_periodic_surface`) and solved on grids (k along, k across) times
finer than the data. The levels along 4 data rows (each a fine row, its line's frame as the job's)
in the data's reported bands are compared with the same surface solved much finer (``--reference``,
default 16 x 16; the pressure along a row is the mean over its width dy, as the job takes it); the
line model on the same rows at k along against k = 64. Printed per setting: the worst difference
(dB) over the budget bands (rows, moduli) of the enveloped and the pressure levels, and the solve
time relative to (1, 1). A benchmark: it prints figures and never fails.

Measured 2026-11-26 (seed 5, 16 mm wide, against (16, 16); worst of the 3 pavements, dB): (1, 1)
8.9, (2, 1) 5.5, (2, 2) 3.7, (4, 1) 5.0, (4, 2) 2.6, (4, 4) 1.5, (8, 1) 4.8, (8, 2) 2.1, (8, 4) 1.0;
time (4, 4) 10 to 15 times (1, 1), (8, 4) 13 to 31. With ``--seeds 5,6 --width 0.008 --reference
32,32 --settings "1,1;2,2;4,4;8,8;16,16"``: 8.1, 2.7, 0.91, 0.33, 0.13 dB, time x 1, 2.7, 10, 40,
200. Refining along the road alone leaves 4 to 5 dB: k goes both ways. With ``--single-row`` the
pressure does not converge (5 to 7 dB at (4, 4) and (8, 4)). (All these with the bilinear road.)
2026-11-27 (issue 39, seed 5, 8 mm wide, against (16, 16) of the same road, ``--settings
"2,2;4,4;6,6;8,8"``): bilinear 2.65, 0.86, 0.43, 0.25 dB; pchip 1.39, 0.53, 0.25, 0.15 dB.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
import polars as pl

from roadtex.budget.noise import in_budget
from roadtex.budget.study import contact_levels, difference
from roadtex.models.contact import contact_many
from roadtex.models.grid import DEFAULT_INTERPOLANT, INTERPOLANTS, Interpolant, refine_periodic, refine_periodic_surface
from roadtex.models.surface import contact_surface_many
from roadtex.profiles.trend import remove_lines
from roadtex.spectra.levels import band_levels
from roadtex.surfaces import synthetic_surface

KINDS = ("dense_asphalt", "porous_asphalt", "cement_concrete")
DX = 1e-3
LENGTH = 0.128
MODULI = np.array([1e6, 2e6, 5e6, 1e7])
PRESSURE = 2e5
SETTINGS = ((1, 1), (2, 1), (2, 2), (4, 1), (4, 2), (4, 4), (8, 1), (8, 2), (8, 4), (8, 8), (16, 16))


def strip(field: np.ndarray, rows: np.ndarray, ky: int) -> np.ndarray:
    """(..., ny ky, nx k) -> (..., rows, nx k): the mean over each data row's width dy (the fine rows
    within dy / 2, trapezoid-weighted); ``--single-row``: the data row's fine row alone."""
    if ky == 1 or SINGLE_ROW:
        return field[..., rows * ky, :]
    offsets = np.arange(-(ky // 2), ky // 2 + 1)
    weights = np.ones(offsets.size)
    if ky % 2 == 0:
        weights[[0, -1]] = 0.5
    weights /= weights.sum()
    n = field.shape[-2]
    return sum(w * field[..., (rows * ky + o) % n, :] for o, w in zip(offsets, weights))


SINGLE_ROW = False
ROAD: Interpolant = DEFAULT_INTERPOLANT   # --interpolant


def areal(tile: np.ndarray, rows: np.ndarray, shift: np.ndarray, k: int, ky: int,
          bands: np.ndarray) -> tuple[np.ndarray, float]:
    """Levels (2, rows x moduli, bands) along data ``rows`` of ``tile`` solved (k, ky) times finer."""
    fine = refine_periodic_surface(tile, k, ky, ROAD)
    start = time.perf_counter()
    solved = contact_surface_many(fine[None], DX / k, DX / ky, youngs_modulus=MODULI, mean_pressure=PRESSURE,
                                  tol=1e-10, warm_start=True, threads=1)
    seconds = time.perf_counter() - start
    envelope = solved.envelope[0][:, rows * ky] - refine_periodic(shift, k, ROAD)[None]
    pressure = strip(solved.pressure[0], rows, ky)
    levels, _ = contact_levels(np.moveaxis(envelope, 0, 1), np.moveaxis(pressure, 0, 1), DX / k, bands, "third_octave")
    return levels, seconds


def line(lines: np.ndarray, k: int, bands: np.ndarray) -> np.ndarray:
    batch = contact_many(refine_periodic(lines, k, ROAD), DX / k, MODULI, PRESSURE, tol=1e-10, warm_start=True, threads=1)
    return contact_levels(batch.envelope, batch.pressure, DX / k, bands, "third_octave")[0]


def bench_case(kind: str, width: float, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                                        np.ndarray, np.ndarray]:
    """One bench surface (LENGTH x ``width`` at DX, its mean removed) and what the benches compare on
    it: (tile, the 4 analysed rows, those rows with their lines removed, the lines themselves (the
    areal envelope's shift), the reported band numbers, which of them are budget bands)."""
    surface = synthetic_surface(kind, LENGTH, width, DX, seed=seed)
    tile = surface.heights - surface.heights.mean()
    rows = np.linspace(0, tile.shape[0] - 1, 4).round().astype(int)
    lines = remove_lines(tile[rows])[0]
    shift = tile[rows] - lines
    bands = band_levels(lines, DX, periodic=True).bands.filter(pl.col("reported"))["band"].to_numpy()
    return tile, rows, lines, shift, bands, in_budget(bands, DX, LENGTH)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", default="5,6")
    parser.add_argument("--width", type=float, default=0.016)
    parser.add_argument("--reference", default="16,16")
    parser.add_argument("--settings", default=None, help="k,ky;k,ky;... instead of the default ladder")
    parser.add_argument("--single-row", action="store_true",
                        help="the pressure along the data row's fine row alone, not the mean over its width")
    parser.add_argument("--interpolant", choices=INTERPOLANTS, default=DEFAULT_INTERPOLANT,
                        help="the road between readings (default: the job's)")
    args = parser.parse_args()
    global SINGLE_ROW, ROAD
    SINGLE_ROW, ROAD = args.single_row, args.interpolant
    settings = SETTINGS if args.settings is None else tuple(
        tuple(int(v) for v in pair.split(",")) for pair in args.settings.split(";"))
    ref_k, ref_ky = (int(v) for v in args.reference.split(","))
    warnings.simplefilter("ignore")
    worst: dict[tuple[int, int], list[float]] = {}
    for kind in KINDS:
        for seed in (int(s) for s in args.seeds.split(",")):
            tile, rows, lines, shift, bands, budget = bench_case(kind, args.width, seed)
            reference, ref_seconds = areal(tile, rows, shift, ref_k, ref_ky, bands)
            line_reference = line(lines, 64, bands)
            base = None
            print(f"{kind} seed {seed}, {tile.shape[0]} x {tile.shape[1]} points; reference ({ref_k}, {ref_ky}) "
                  f"{ref_seconds:.2f} s", flush=True)
            for k, ky in settings:
                levels, seconds = areal(tile, rows, shift, k, ky, bands)
                base = seconds if base is None else base
                gap = difference(levels, reference)[..., budget].max(axis=(1, 2))
                worst.setdefault((k, ky), []).append(float(gap.max()))
                text = f"  areal ({k}, {ky}): enveloped {gap[0]:6.3f} pressure {gap[1]:6.3f} dB, time x{seconds / base:5.1f}"
                if ky == 1:
                    lgap = difference(line(lines, k, bands), line_reference)[..., budget].max(axis=(1, 2))
                    text += f" | line k {k}: {lgap[0]:6.3f} / {lgap[1]:6.3f} dB"
                print(text, flush=True)
    print("# worst over every case (enveloped or pressure, budget bands):")
    for setting, values in worst.items():
        print(f"  {setting}: {max(values):.3f} dB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
