"""The seed's statements (figures 4.3, 4.4, 4.6) checked on the CAPTIF profiles and the synthetic
pavements with one call of roadtex.comparisons each; prints the README's tables.

    .venv/bin/python benches/seed_statements.py [--captif DIR]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import polars as pl

import roadtex
from roadtex import comparisons as cmp
from roadtex.profiles.trend import remove_lines

CAPTIF = Path(__file__).resolve().parents[2] / "shared" / "data" / "captif-slp"
SYNTHETIC = ("dense_asphalt", "porous_asphalt", "cement_concrete", "surface_dressing")


def captif(path: Path, dx: float) -> np.ndarray:
    z = np.asarray(roadtex.read_profile(path).conditioned(dx=dx).heights)
    return remove_lines(z[None, :])[0][0]


def bracket(row: dict) -> str:
    low, high = row["modulus_below"], row["modulus_above"]
    if low is None:
        return "< 1"
    if high is None:
        return "> 10"
    return f"{low / 1e6:g}-{high / 1e6:g}"


def exponent(summary: pl.DataFrame, modulus: str) -> float:
    """Log-log slope of the INRETS median penetration against the median width, narrowest to widest."""
    y, w = summary[f"inrets_median_{modulus}MPa"].to_numpy(), summary["width_median"].to_numpy()
    if y[0] <= 0 or y[-1] <= 0 or w[-1] <= w[0]:
        return float("nan")
    return float(np.log(y[-1] / y[0]) / np.log(w[-1] / w[0]))


def figure_4_3(files: list[Path]) -> None:
    print("Figure 4.3: E interval (MPa) holding the von Meier median, narrowest and widest third of the "
          "valleys; INRETS penetration ~ width^a (a at 1 and 2 MPa; von Meier: 2)\n")
    print("| profile | dx (mm) | P (MPa) | widths (mm) | narrowest | widest | a (1, 2 MPa) | seed holds |")
    print("|---|---|---|---|---|---|---|---|")
    cases = [(f"CAPTIF {p.stem.rsplit('_', 1)[-1]}", lambda dx, p=p: captif(p, dx)) for p in files]
    cases += [(k.replace("_", " "), lambda dx, k=k: np.asarray(roadtex.synthetic_pavement(k, 2.0, dx, seed=1).heights))
              for k in SYNTHETIC]
    for dx in (0.1e-3, 0.5e-3, 1e-3, 2e-3):
        for pressure in ((1e5, 2e5, 5e5) if dx == 0.1e-3 else (2e5,)):
            for name, heights in cases:
                check = cmp.penetration_ranking(heights(dx), dx, mean_pressure=pressure, classes=3)
                s = check.summary
                narrow, wide = s.row(0, named=True), s.row(s.height - 1, named=True)
                print(f"| {name} | {dx * 1e3:g} | {pressure / 1e6:g} | {narrow['width_median'] * 1e3:.1f} to "
                      f"{wide['width_median'] * 1e3:.1f} | {bracket(narrow)} | {bracket(wide)} | "
                      f"{exponent(s, '1'):.2f}, {exponent(s, '2'):.2f} | {'yes' if check.holds else 'no'} |")


def figure_4_4() -> None:
    dx = 0.1e-3
    profiles = {k: roadtex.synthetic_pavement(k, 4.0, dx, seed=1).heights for k in ("porous_asphalt", "dense_asphalt")}
    check = cmp.depth_effect(profiles, dx, porous="porous_asphalt", dense="dense_asphalt", segment_length=0.2)
    print(f"\nFigure 4.4: porous minus dense asphalt (dB), synthetic, 4 m at 0.1 mm, 0.2 m segments; "
          f"holds: {check.holds}\n")
    wide = check.summary.pivot(on="youngs_modulus", index=["band", "label"], values="depth_effect_enveloped_db")
    original = check.summary.filter(pl.col("youngs_modulus") == 1e6).select("band", "depth_effect_original_db")
    wide = wide.join(original, on="band").sort("band")
    print("| band (mm) | original | enveloped, E = 1 | 2 | 5 | 10 MPa |\n|---|---|---|---|---|---|")
    for row in wide.iter_rows(named=True):
        values = [row[c] for c in ("1000000.0", "2000000.0", "5000000.0", "10000000.0")]
        print(f"| {row['label']} | {row['depth_effect_original_db']:+.1f} | " + " | ".join(f"{v:+.1f}" for v in values)
              + " |")


def figure_4_6(files: list[Path]) -> None:
    dx = 0.1e-3
    profiles = {p.stem.rsplit("_", 1)[-1]: captif(p, dx) for p in files}
    check = cmp.pressure_texture_fits(profiles, dx, segment_length=0.1)
    print(f"\nFigure 4.6: pressure level against enveloped texture level per octave band, CAPTIF, "
          f"0.1 m segments ({check.data['segment'].n_unique()} per file); holds: {check.holds}\n")
    print("| band (mm) | E (MPa) | slope | intercept (dB) | r2 | scatter (dB) | n |\n|---|---|---|---|---|---|---|")
    for row in check.summary.iter_rows(named=True):
        print(f"| {row['label']} | {row['youngs_modulus'] / 1e6:g} | {row['slope']:.2f} | {row['intercept']:.1f} | "
              f"{row['r2']:.3f} | {row['scatter_db']:.2f} | {row['n']} |")
    dense = {k: roadtex.synthetic_pavement(k, 2.0, dx, seed=1).heights for k in SYNTHETIC}
    synthetic = cmp.pressure_texture_fits(dense, dx, segment_length=0.1)
    s = synthetic.summary
    print(f"\nSynthetic pavements pooled (4 x 20 segments): slopes {s['slope'].min():.2f} to {s['slope'].max():.2f}, "
          f"r2 {s['r2'].min():.3f} to {s['r2'].max():.3f}, scatter {s['scatter_db'].min():.2f} to "
          f"{s['scatter_db'].max():.2f} dB; holds: {synthetic.holds}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--captif", type=Path, default=CAPTIF)
    args = parser.parse_args()
    files = sorted(args.captif.glob("*.dat"))
    figure_4_3(files)
    figure_4_4()
    figure_4_6(files)


if __name__ == "__main__":
    main()
