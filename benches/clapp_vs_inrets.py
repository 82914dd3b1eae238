"""Clapp's model against the periodic INRETS model on the same rough profiles: error and time.

Run from the project root:

    .venv/bin/python benches/clapp_vs_inrets.py              # default, about two minutes on 2 cores
    .venv/bin/python benches/clapp_vs_inrets.py --quick      # one profile, two moduli: a smoke run
    .venv/bin/python benches/clapp_vs_inrets.py --threads 2  # both models may use 2 threads
    .venv/bin/python benches/clapp_vs_inrets.py --json rows.json

This is a benchmark, not a test: it prints tables and never fails on a number.

Profiles. The demo's road-like synthetic profiles (``roadtex.synthetic.self_affine_profile``:
Hurst 0.8, rms slope 0.2, wavelengths from the sample length L = N dx down to 4 dx), N = 8,192
points at dx = 0.05 mm (L = 410 mm), seeds 0 and 1; P = 0.2 MPa, E = 1, 2.5, 5, 10 MPa, nu = 0.5.
A second family, "short", is the same profiles with every wavelength longer than 12.8 mm removed
(Fourier modes zeroed), so that the texture fits inside one Clapp core: it separates Clapp's own
window error from its blindness to wavelengths longer than a core.

Models. Reference: ``roadtex.contact`` (periodic INRETS model, element kernel, CG, tol 1e-10).
Clapp: ``roadtex.clapp`` with ``wrap=True`` (the profile taken as periodic when cutting its end
windows, as the reference takes it) and the sub-profile / overlap pairs of --windows (default
512/128, 1024/256 = the library default, 2048/512: the core is always half the window).

Columns
  contact   contact fraction, INRETS / Clapp.
  L1, L2    relative pressure error of Clapp against INRETS: sum|dp| / sum p and ||dp||_2 / ||p||_2.
  env       envelope error: mean |e_clapp - e_inrets| over the INRETS mean depth of the envelope
            above the road, mean(e_inrets - z). Clapp's envelope is straight lines between contacts,
            INRETS's the elastic surface.
  depth     mean depth of the envelope above the road, Clapp over INRETS: mean(e_clapp - z) /
            mean(e_inrets - z) (above 1: the straight lines bridge higher than the rubber sags).
  t_inrets, t_clapp   wall time of one call, best of --repeats (one run when a call takes > 2 s).
  ratio     t_clapp / t_inrets.

By default both models run on one thread (RAYON_NUM_THREADS=1, set before roadtex is imported):
Clapp solves its windows in parallel, so --threads 2 shows what that buys.
"""

from __future__ import annotations

import argparse
import os
import sys


def _parse() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="one profile, two moduli, default windows")
    parser.add_argument("--threads", type=int, default=1, help="RAYON_NUM_THREADS (default 1)")
    parser.add_argument("--repeats", type=int, default=3, help="best of this many runs (default 3)")
    parser.add_argument("--windows", default="512/128,1024/256,2048/512",
                        help="sub_profile/overlap pairs, comma-separated")
    parser.add_argument("--json", help="also write the rows to this JSON file")
    return parser.parse_args()


ARGS = _parse() if __name__ == "__main__" else None
if ARGS is not None:
    os.environ["RAYON_NUM_THREADS"] = str(ARGS.threads)

import json  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from typing import Callable  # noqa: E402

import numpy as np  # noqa: E402

import roadtex  # noqa: E402
from roadtex.models.clapp import clapp  # noqa: E402
from roadtex.profiles.synthetic import self_affine_profile  # noqa: E402

N = 8192
DX = 5e-5
P = 2e5
SHORT_WAVELENGTH = 0.0128  # m: the "short" family keeps wavelengths up to this


def best_time(call: Callable[[], object], repeats: int) -> tuple[float, object]:
    best, result = float("inf"), None
    for k in range(repeats):
        start = time.perf_counter()
        result = call()
        elapsed = time.perf_counter() - start
        best = min(best, elapsed)
        if elapsed > 2.0 and k == 0:
            break
    return best, result


def profiles(seeds: list[int]) -> list[tuple[str, int, np.ndarray]]:
    out = []
    for seed in seeds:
        z = self_affine_profile(N, N * DX, hurst=0.8, rms_slope=0.2, cutoff_fraction=0.25, seed=seed)
        out.append(("road", seed, z))
        spectrum = np.fft.rfft(z)
        wavelengths = np.full(spectrum.size, np.inf)
        wavelengths[1:] = N * DX / np.arange(1, spectrum.size)
        spectrum[wavelengths > SHORT_WAVELENGTH] = 0.0
        out.append(("short", seed, np.fft.irfft(spectrum, N)))
    return out


def main() -> int:
    args = ARGS
    assert args is not None
    windows = [tuple(int(v) for v in pair.split("/")) for pair in args.windows.split(",")]
    seeds, moduli = ([0], [2.5e6, 1e7]) if args.quick else ([0, 1], [1e6, 2.5e6, 5e6, 1e7])
    if args.quick:
        windows = [(1024, 256)]
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"clapp_vs_inrets: N = {N}, dx = {DX * 1e3:g} mm, P = {P / 1e6:g} MPa, threads = {args.threads}, "
          f"python {platform.python_version()}, load average {load:.2f}")
    header = (f"{'profile':>8} {'seed':>4} {'E MPa':>5} {'window':>9} {'contact':>11} {'L1':>7} {'L2':>7} "
              f"{'env':>7} {'depth':>6} {'t_inrets':>9} {'t_clapp':>9} {'ratio':>7}")
    print(header)
    print("-" * len(header))
    rows = []
    for family, seed, z in profiles(seeds):
        for modulus in moduli:
            t_ref, ref = best_time(lambda: roadtex.contact(z, DX, modulus, P, tol=1e-10), args.repeats)
            depth = float(np.mean(ref.envelope - z))
            for sub, lap in windows:
                t_c, res = best_time(lambda: clapp(z, DX, modulus, P, sub_profile=sub, overlap=lap, wrap=True),
                                     args.repeats)
                dp = res.pressure - ref.pressure
                row = {
                    "profile": family, "seed": seed, "youngs_modulus": modulus, "sub_profile": sub, "overlap": lap,
                    "contact_inrets": ref.contact_fraction, "contact_clapp": res.contact_fraction,
                    "l1": float(np.abs(dp).sum() / ref.pressure.sum()),
                    "l2": float(np.linalg.norm(dp) / np.linalg.norm(ref.pressure)),
                    "envelope": float(np.mean(np.abs(res.envelope - ref.envelope)) / depth),
                    "depth_ratio": float(np.mean(res.envelope - z) / depth),
                    "t_inrets": t_ref, "t_clapp": t_c, "ratio": t_c / t_ref, "sweeps": res.sweeps,
                }
                rows.append(row)
                print(f"{family:>8} {seed:>4} {modulus / 1e6:>5g} {f'{sub}/{lap}':>9} "
                      f"{row['contact_inrets']:>5.2f}/{row['contact_clapp']:<5.2f} {row['l1']:>7.3f} {row['l2']:>7.3f} "
                      f"{row['envelope']:>7.3f} {row['depth_ratio']:>6.2f} {t_ref:>8.3f}s {t_c:>8.3f}s {row['ratio']:>6.1f}x", flush=True)
    print()
    print("Means over profiles and seeds, per family, modulus and window:")
    keys = sorted({(r["profile"], r["youngs_modulus"], r["sub_profile"]) for r in rows})
    for family, modulus, sub in keys:
        sel = [r for r in rows if (r["profile"], r["youngs_modulus"], r["sub_profile"]) == (family, modulus, sub)]
        mean = {k: float(np.mean([r[k] for r in sel])) for k in ("l1", "l2", "envelope", "depth_ratio", "t_inrets", "t_clapp", "ratio")}
        print(f"  {family:>6} E = {modulus / 1e6:>4g} MPa, window {sub:>5}: L1 {mean['l1']:.3f}, L2 {mean['l2']:.3f}, "
              f"envelope {mean['envelope']:.3f}, depth {mean['depth_ratio']:.2f}, time {mean['t_clapp']:.3f} s vs {mean['t_inrets']:.3f} s "
              f"({mean['ratio']:.1f}x)")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(rows, handle, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
