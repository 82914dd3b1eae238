"""Start-up time (issue 39): ``roadtex --version``, ``roadtex --help`` and ``import roadtex``, each a
fresh interpreter, as a user's shell starts them.

    .venv/bin/python benches/startup.py               # 15 runs of each, the median and the best
    .venv/bin/python benches/startup.py --runs 30

Each command runs ``--runs`` times after one warm-up run (the file cache), one after the other;
the median and best wall-clock times are printed, and the modules each one imported (counted in the
child). A benchmark: it prints, it never fails on a number. For where the time goes:
``python -X importtime -c "import roadtex"``.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

COMMANDS = {
    "roadtex --version": "import sys; from roadtex.cli import main; sys.argv[0] = 'roadtex'; main(['--version'])",
    "roadtex --help": "import sys; from roadtex.cli import main; sys.argv[0] = 'roadtex'; main(['--help'])",
    "import roadtex": "import roadtex",
}


def modules_loaded(code: str) -> int:
    count = f"{code}\n" if "main(" not in code else f"try:\n    {code.replace('; ', chr(10) + '    ')}\nexcept SystemExit:\n    pass\n"
    out = subprocess.run([sys.executable, "-c", count + "import sys; print(len(sys.modules), file=sys.stderr)"],
                         capture_output=True, text=True, check=True)
    return int(out.stderr.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=15, help="runs of each command (default 15)")
    args = parser.parse_args()
    print(f"{'command':<20} {'median s':>9} {'best s':>8} {'modules':>8}   ({args.runs} runs, {sys.executable})")
    for name, code in COMMANDS.items():
        times = []
        for run in range(args.runs + 1):
            start = time.perf_counter()
            subprocess.run([sys.executable, "-c", code], stdout=subprocess.DEVNULL, check=True)
            if run:   # the first run warms the file cache
                times.append(time.perf_counter() - start)
        print(f"{name:<20} {statistics.median(times):>9.3f} {min(times):>8.3f} {modules_loaded(code):>8}")


if __name__ == "__main__":
    main()
