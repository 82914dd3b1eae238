"""Regenerates the sampling calibration (issue 33) from the CAPTIF files and checks it, leave one out.

    .venv/bin/python benches/sampling_calibration.py              # writes the shipped table, prints the figures
    .venv/bin/python benches/sampling_calibration.py --out /tmp/calibration.csv --step 0.5

Each CAPTIF file (0.0375 mm) is cut into 0.5 m segments every --step m (the job's conditioning),
each segment averaged to every sampling of roadtex.budget.sampling_calibration.DEFAULT_SAMPLINGS
(interval averages at 0.05, 0.1, 0.25, 0.5, 1 mm; a 0.2 mm spot sampled every 0.5 and 1 mm), both solved
converged (the job's road, monotone cubics since 0.5.0, model dx <= 0.03 mm for the averaged data; the
fine data's linear road at 0.019 mm) at
E = 1, 2, 5, 10 MPa; the table (roadtex.budget.sampling.summarise) is written to --out. Then the
full leave-one-out: each file's run-mean difference against a calibration of the other two, per
sampling: the share of band x E cases the stated run-mean uncertainty covers, and the median of
stated / actual, uncorrected and corrected. Prints; never fails on a number.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import polars as pl

import roadtex
from roadtex.budget.sampling import summarise
from roadtex.budget.sampling_calibration import DEFAULT_SAMPLINGS, file_differences, leave_one_out
from roadtex.models.grid import DEFAULT_INTERPOLANT

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "captif-slp"
SHIPPED = Path(__file__).resolve().parents[1] / "python" / "roadtex" / "budget" / "data" / "sampling_calibration.csv"
MODULI = (1e6, 2e6, 5e6, 1e7)


def header(files: list[Path], step: float) -> str:
    cases = ", ".join(f"{dx * 1e3:g}/{w * 1e3:g}" for dx, w in DEFAULT_SAMPLINGS)
    return "\n".join([
        f"# roadtex sampling calibration, format 1, made by benches/sampling_calibration.py (roadtex {roadtex.__version__})",
        f"# from {', '.join(f.name for f in files)} (CAPTIF SLP, 0.0375 mm, MIT licence), 0.5 m segments every {step:g} m",
        f"# samplings dx/width (mm): {cases}; E = {', '.join(f'{e / 1e6:g}' for e in MODULI)} MPa; P = 0.2 MPa",
        f"# coarse readings joined as the job joins them ({DEFAULT_INTERPOLANT}), the fine ones linearly, each solved converged",
        "# level: enveloped (dB re 1 um) or pressure (dB re 1 Pa); dx, width, centre_wavelength in m; youngs_modulus in Pa;",
        "# bias_db = mean(coarse - fine), within_sd_db / between_sd_db = scatter of segments in a file / of files' means,",
        "# bias_se_db = standard error of bias_db; files, segments = counts; between_floored = between_sd_db at the floor",
        "# three files can resolve (their means' own noise: see roadtex.budget.sampling)",
    ]) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DATA, help="folder of the CAPTIF .dat files")
    parser.add_argument("--out", type=Path, default=SHIPPED, help="where to write the table")
    parser.add_argument("--step", type=float, default=0.25, help="segment starts every STEP m (overlap when < 0.5)")
    args = parser.parse_args()
    files = sorted(args.data.glob("*.dat"))
    if len(files) < 2:
        raise SystemExit(f"no CAPTIF files in {args.data}")
    started = time.perf_counter()
    differences = pl.concat([file_differences(f, youngs_moduli=MODULI, step=args.step) for f in files])
    print(f"{differences.height} differences from {len(files)} files in {time.perf_counter() - started:.0f} s")
    table = pl.concat([summarise(differences, level) for level in ("enveloped", "pressure")])
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w") as handle:
        handle.write(header(files, args.step))
        decibels = [c for c in table.columns if c.endswith("_db")]
        table.with_columns(pl.col(decibels).round(4)).write_csv(handle)
    print(f"wrote {args.out} ({table.height} rows)")

    enveloped = table.filter(pl.col("level") == "enveloped")
    for dx, width in DEFAULT_SAMPLINGS:
        print(f"\nenveloped, dx {dx * 1e3:g} mm, width {width * 1e3:g} mm: bias / within sd / between sd (dB)")
        rows = enveloped.filter((pl.col("dx") == dx) & (pl.col("width") == width)).sort("band")
        for e in (2e6, 1e7):
            cells = rows.filter(pl.col("youngs_modulus") == e)
            print(f"  E {e / 1e6:g} MPa  " + "  ".join(
                f"{r['label']}:{r['bias_db']:+.2f}/{r['within_sd_db']:.2f}/{r['between_sd_db']:.2f}"
                for r in cells.iter_rows(named=True)))

    print("\nleave one out (run mean of each held-out file's non-overlapping segments, band x E x file cases):")
    for correct in (False, True):
        result = leave_one_out(differences, correct=correct).with_columns(
            (pl.col("stated_db") / pl.col("actual_db").abs()).alias("ratio"))
        summary = result.group_by("dx", "width").agg(pl.len().alias("cases"), pl.col("covered").mean().alias("covered"),
                                                      pl.col("ratio").median().alias("median_stated_over_actual"),
                                                      pl.col("segments_covered").mean())
        print(f"  {'corrected' if correct else 'uncorrected'}: all {result['covered'].mean():.1%} covered, "
              f"median stated/actual {result['ratio'].median():.2f}; single segments "
              f"{result['segments_covered'].mean():.1%} covered by the one-segment figure")
        for row in summary.sort("dx", "width").iter_rows(named=True):
            print(f"    dx {row['dx'] * 1e3:g} mm width {row['width'] * 1e3:g} mm: {row['cases']} cases, "
                  f"{row['covered']:.1%} covered, median stated/actual {row['median_stated_over_actual']:.2f}; "
                  f"single segments {row['segments_covered']:.1%}")


if __name__ == "__main__":
    main()
