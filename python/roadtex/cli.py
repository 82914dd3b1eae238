"""The ``roadtex`` command line."""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
import polars as pl

from roadtex.contact import contact_many
from roadtex.synthetic import self_affine_profile


def demo(args: argparse.Namespace) -> int:
    """Solves built-in rough road-like profiles at several rubber moduli and prints a summary."""
    n, dx = args.points, args.dx
    length = n * dx
    segments = np.stack([
        # Road-like texture: rms slope 0.2 over macro/megatexture wavelengths down to 4 dx.
        self_affine_profile(n, length, hurst=0.8, rms_slope=0.2, cutoff_fraction=0.25, seed=seed)
        for seed in range(args.segments)
    ])
    moduli = np.array(args.moduli, dtype=float) * 1e6
    pressure = args.pressure * 1e6
    print(f"roadtex demo: {args.segments} synthetic self-affine profiles, {n} points at dx = {dx * 1e3:g} mm "
          f"(L = {length * 1e3:.0f} mm), rms height {segments.std(axis=1).mean() * 1e3:.2f} mm; "
          f"periodic INRETS model, mean pressure {args.pressure:g} MPa, nu = 0.5")
    start = time.perf_counter()
    batch = contact_many(segments, dx, moduli, pressure, tol=args.tol)
    elapsed = time.perf_counter() - start
    rows = []
    for result in batch:
        rows.append({
            "E (MPa)": result.youngs_modulus / 1e6,
            "contact (%)": 100 * result.contact_fraction,
            "max pressure (MPa)": float(result.pressure.max()) / 1e6,
            "mean depth below envelope (mm)": float(result.depth_below_envelope.mean()) * 1e3,
            "iterations": result.iterations,
            "residual": result.residual,
        })
    table = (pl.DataFrame(rows).group_by("E (MPa)", maintain_order=True)
             .agg(pl.exclude("residual").mean(), pl.col("residual").max().alias("worst residual"))
             .sort("E (MPa)")
             .with_columns(pl.col("worst residual").map_elements(lambda r: f"{r:.1e}", return_dtype=pl.String)))
    with pl.Config(tbl_rows=50, tbl_cols=10, float_precision=3, tbl_width_chars=160):
        print(table)
    print(f"solved {len(batch)} contact problems in {elapsed:.2f} s (means over profiles per modulus; "
          f"residual: worst gap/penetration relative to the profile height, tolerance {args.tol:g})")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="roadtex", description="Tyre/road contact and texture envelopment.")
    commands = parser.add_subparsers(dest="command", required=True)
    d = commands.add_parser("demo", help="solve built-in rough profiles at several moduli and print a summary")
    d.add_argument("--points", type=int, default=8192, help="points per profile (default 8192)")
    d.add_argument("--dx", type=float, default=5e-5, help="sampling interval in metres (default 5e-5)")
    d.add_argument("--segments", type=int, default=8, help="number of profiles (default 8)")
    d.add_argument("--moduli", type=float, nargs="+", default=[1.0, 2.5, 5.0, 10.0],
                   help="Young's moduli in MPa (default 1 2.5 5 10)")
    d.add_argument("--pressure", type=float, default=0.2, help="mean pressure in MPa (default 0.2)")
    d.add_argument("--tol", type=float, default=1e-8, help="solver tolerance (default 1e-8)")
    d.set_defaults(run=demo)
    args = parser.parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
