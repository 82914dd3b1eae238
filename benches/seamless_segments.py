"""Seamless segments: each 0.5 m segment less the line through its ends (the default) against its
least-squares line (before), on synthetic dense and porous asphalt and the CAPTIF files, at 0.5 and
0.1 mm; prints the tables of the README's "Seamless segments".

    .venv/bin/python benches/seamless_segments.py [--dx 0.5e-3 0.1e-3] [--captif DIR]

1. The end estimate: periodic levels of the original segments, detrended five ways, minus the whole
   record's Hann-windowed levels (the independent reference): least squares; the line through the
   end samples (the default); through the sample extrapolated past the end (the reviewer's); through
   the means of 0.5 mm and of 2 mm at each end.
2. Before and after, E = 2.5 MPa, P = 0.2 MPa: original levels against whole-record Hann, enveloped
   and pressure levels, contact fraction.
3. What users read, enveloped minus original, against the same difference of the whole record
   solved as one period (its seams 20 to 40 times rarer), both Hann-windowed.
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np

import roadtex
from roadtex.profiles.trend import remove_end_lines, remove_lines
from roadtex.spectra import band_levels

CAPTIF = Path(__file__).resolve().parents[2] / "shared" / "data" / "captif-slp"
SEGMENT = 0.5
E, P = 2.5e6, 2e5


def end_estimate(raw: np.ndarray, how: str, dx: float) -> np.ndarray:
    """Segments (rows of ``raw``) less a line that closes their wrap step as estimated by ``how``."""
    n = raw.shape[1]
    if how == "least squares":
        return remove_lines(raw)[0]
    if how == "ends":
        return remove_end_lines(raw)[0]
    if how == "extrapolated":   # the next sample, extrapolated from the last two, meets the first
        jump = 2 * raw[:, -1] - raw[:, -2] - raw[:, 0]
    else:                       # "mean X mm": the means of X mm at each end, at their centres
        m = max(1, int(round(float(how.split()[1]) * 1e-3 / dx)))
        jump = (raw[:, -m:].mean(axis=1) - raw[:, :m].mean(axis=1)) * n / (n - m)
    z = raw - jump[:, None] * np.arange(n) / n
    return z - z.mean(axis=1, keepdims=True)


def levels(values: np.ndarray, dx: float, periodic: bool = True, reference: float = 1e-6) -> np.ndarray:
    """Energy mean over rows of the band levels (dB re ``reference``)."""
    if periodic:
        result = band_levels(values, dx, periodic=True, reference=reference)
    else:
        result = band_levels(values, dx, periodic=False, reference=reference)
    with np.errstate(divide="ignore"):
        return 10 * np.log10(result.mean_square.mean(axis=0) / reference**2)


def cases(dx: float, captif: Path, seeds: list[int]) -> list[tuple[str, roadtex.Profile]]:
    length = 20.0 if dx >= 0.5e-3 else 10.0
    out = [(f"{kind}, seed {seed}", roadtex.synthetic_pavement(kind, length, dx, seed=seed).conditioned())
           for seed in seeds for kind in ("dense_asphalt", "porous_asphalt")]
    out += [("CAPTIF " + p.stem.rsplit("_", 1)[-1], roadtex.read_profile(p).conditioned(dx=dx))
            for p in sorted(captif.glob("*.dat"))]
    return out


def rms(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(values**2)))


def report(name: str, profile: roadtex.Profile) -> None:
    dx = profile.dx
    raw = profile.segments(SEGMENT, detrend=False).heights
    bands = band_levels(raw[:1], dx, periodic=True).bands
    shown = np.flatnonzero(bands["reported"].to_numpy())
    label = bands["label"].to_list()
    centre = bands["centre_wavelength"].to_numpy()
    hann = levels(profile.heights[None, :], dx, periodic=False)
    print(f"\n### {name}, dx {dx * 1e3:.4g} mm, {raw.shape[0]} segments of {SEGMENT:g} m\n")

    ways = ("least squares", "ends", "extrapolated", "mean 0.5", "mean 2")
    minus = {w: levels(end_estimate(raw, w, dx), dx) - hann for w in ways}
    print("1. Original, periodic minus whole-record Hann (dB), by end estimate\n")
    print("| band (mm) | " + " | ".join(ways) + " |\n" + "|---" * (len(ways) + 1) + "|")
    for i in shown:
        print(f"| {label[i]} | " + " | ".join(f"{minus[w][i]:+.2f}" for w in ways) + " |")
    short = shown[-4:]
    print("| rms, 4 shortest | " + " | ".join(f"{rms(minus[w][short]):.2f}" for w in ways) + " |")

    whole = roadtex.contact(profile.heights, dx, E, P, tol=1e-8)
    whole_difference = (levels(whole.envelope[None, :], dx, periodic=False) - hann)
    solved = {}
    for way in ("least_squares", "ends"):
        s = profile.segments(SEGMENT, detrend=way)
        batch = roadtex.contact_many(s.heights, dx, [E], P, tol=1e-8)
        steps = s.heights[:, -1] - s.heights[:, 0]
        solved[way] = dict(original=levels(s.heights, dx), enveloped=levels(batch.envelope[:, 0], dx),
                           pressure=levels(batch.pressure[:, 0], dx, reference=1.0), step=rms(steps),
                           contact=float(batch.measures()["contact_fraction"].mean()))
    old, new = solved["least_squares"], solved["ends"]
    print(f"\n2. Before (least squares) and after (ends), E = {E / 1e6:g} MPa, P = {P / 1e6:g} MPa: rms end step "
          f"{old['step'] * 1e3:.2f} -> {new['step'] * 1e3:.1g} mm; contact fraction {old['contact']:.4f} -> "
          f"{new['contact']:.4f} (whole record as one period: {whole.contact_fraction:.4f})\n")
    print("| band (mm) | Hann (dB) | original before - Hann | after - Hann | enveloped after - before | "
          "pressure after - before | (env. - orig.) before - whole record | after - whole record |")
    print("|---|---|---|---|---|---|---|---|")
    errors = {}
    for way, row in solved.items():
        errors[way] = row["enveloped"] - row["original"] - whole_difference
    for i in shown:
        print(f"| {label[i]} | {hann[i]:.1f} | {old['original'][i] - hann[i]:+.2f} | {new['original'][i] - hann[i]:+.2f} | "
              f"{new['enveloped'][i] - old['enveloped'][i]:+.2f} | {new['pressure'][i] - old['pressure'][i]:+.2f} | "
              f"{errors['least_squares'][i]:+.2f} | {errors['ends'][i]:+.2f} |")
    for span, pick in (("<= 2.5 mm", shown[centre[shown] <= 2.6e-3]),
                       ("3.15 to 16 mm", shown[(centre[shown] > 2.6e-3) & (centre[shown] < 17e-3)]),
                       (">= 20 mm", shown[centre[shown] >= 19e-3])):
        print(f"| rms {span} | | {rms(old['original'][pick] - hann[pick]):.2f} | {rms(new['original'][pick] - hann[pick]):.2f} | "
              f"{rms(new['enveloped'][pick] - old['enveloped'][pick]):.2f} | "
              f"{rms(new['pressure'][pick] - old['pressure'][pick]):.2f} | "
              f"{rms(errors['least_squares'][pick]):.2f} | {rms(errors['ends'][pick]):.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dx", type=float, nargs="+", default=[0.5e-3, 0.1e-3])
    parser.add_argument("--captif", type=Path, default=CAPTIF)
    parser.add_argument("--seeds", type=int, nargs="+", default=[1], help="synthetic profiles' seeds (default 1)")
    args = parser.parse_args()
    warnings.simplefilter("ignore", roadtex.RoadtexWarning)
    for dx in args.dx:
        for name, profile in cases(dx, args.captif, args.seeds):
            report(name, profile)


if __name__ == "__main__":
    main()
