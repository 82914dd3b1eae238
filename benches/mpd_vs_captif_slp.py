"""Mean profile depth of the three CAPTIF chip seals: roadtex against the peer captif-slp 0.22.

    bash scripts/peer-captif-slp.sh install          # once: the peer's own venv, .venv-peers
    .venv/bin/python benches/mpd_vs_captif_slp.py [--alpha 6] [--segments]

Prints, per file, both MPDs, the difference in %, the valid segment counts and the time each
took (the peer's time includes starting its interpreter and importing pandas).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

from roadtex.profiles import mpd, read_profile

REPO = Path(__file__).resolve().parents[1]
DATA = REPO.parent / "shared" / "data" / "captif-slp"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--alpha", type=float, default=6.0, help="spike criterion (captif-slp's authors use 6)")
    parser.add_argument("--segments", action="store_true", help="also print every segment's MSD")
    parser.add_argument("files", nargs="*", type=Path, help="CAPTIF .dat files (default: ../shared/data/captif-slp)")
    args = parser.parse_args()
    files = args.files or sorted(DATA.glob("*.dat"))
    if not files:
        print(f"no CAPTIF files given and none in {DATA}", file=sys.stderr)
        return 2
    if not (REPO / ".venv-peers" / "bin" / "python").exists():
        print("the peer is not installed: bash scripts/peer-captif-slp.sh install", file=sys.stderr)
        return 2

    start = time.perf_counter()
    out = subprocess.run(["bash", str(REPO / "scripts" / "peer-captif-slp.sh"), "mpd", "--alpha", str(args.alpha),
                          *map(str, files)], capture_output=True, text=True, check=True)
    peer_seconds = time.perf_counter() - start
    peers = [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]

    print(f"spike alpha {args.alpha:g}; peer captif-slp 0.22 took {peer_seconds:.2f} s for {len(files)} files")
    print(f"{'file':42s} {'roadtex MPD':>12s} {'peer MPD':>10s} {'diff':>8s} {'valid (ours/peer)':>18s} {'ours':>8s}")
    worst = 0.0
    for path, peer in zip(files, peers):
        start = time.perf_counter()
        ours = mpd(read_profile(path), spike_alpha=args.alpha)
        seconds = time.perf_counter() - start
        ours_mm, peer_mm = ours.mpd * 1e3, peer["mpd_mm"]
        diff = 100.0 * (ours_mm / peer_mm - 1.0)
        worst = max(worst, abs(diff))
        valid = f"{ours.valid_segments}/{len(ours.segments)} vs {peer['valid_segments']}/{len(peer['segments'])}"
        print(f"{path.name:42s} {ours_mm:9.4f} mm {peer_mm:7.4f} mm {diff:+7.2f}% {valid:>18s} {seconds:7.3f}s")
        if args.segments:
            for row, theirs in zip(ours.segments.iter_rows(named=True), peer["segments"]):
                print(f"    segment {row['segment']:2d}: {row['msd'] * 1e3:7.3f} mm {'valid' if row['valid'] else 'INVALID':7s}"
                      f"  peer {theirs['msd_mm']:7.3f} mm {'valid' if theirs['valid'] else 'INVALID'}")
    print(f"largest difference: {worst:.2f} % (target: within 2 %)")
    return 0 if worst < 2.0 else 1


if __name__ == "__main__":
    sys.exit(main())
