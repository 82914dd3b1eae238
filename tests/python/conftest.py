"""Shared fixtures: the real CAPTIF profiles from ../shared (never copied into the repository), and
``tests/python`` on ``sys.path`` so that tests can import the shared independent checker
(``from independent import check_contact``) whatever pytest's import mode."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

#: ../shared/data/captif-slp beside the repository (see the brief: real data lives outside the repo),
#: or beside any folder above it (a git worktree nested one level deeper, /work/wt/NAME, finds
#: /work/shared); ROADTEX_CAPTIF_DIR overrides it.
CAPTIF_DIR = Path(os.environ.get("ROADTEX_CAPTIF_DIR") or next(
    (folder / "shared" / "data" / "captif-slp" for folder in HERE.parents[2:]
     if (folder / "shared" / "data" / "captif-slp").is_dir()),
    HERE.parents[2] / "shared" / "data" / "captif-slp"))

#: The three laser-profilometer files captif-slp publishes (CAPTIF, Aylesbury, 11 October 2021).
CAPTIF_FILE_NAMES = (
    "20211011_aylesbury_dec_station_0.dat",
    "20211011_aylesbury_dec_station_1.dat",
    "20211011_aylesbury_dec_station_10.dat",
)


#: How to run the real-data tests, said in every skip reason and in the test summary.
HOW_TO_RUN = ("to run them, put the three captif-slp .dat files in ../shared/data/captif-slp beside the repository "
              "(never in it), or set ROADTEX_CAPTIF_DIR=/path/to/captif-slp")
#: Marks the skip reasons of the real-data tests, which the summary counts.
REAL_DATA_SKIP = "real CAPTIF profiles"


@pytest.fixture(scope="session")
def captif_dir() -> Path:
    """The folder of the three CAPTIF laser-profilometer files; skips, saying why, when it is absent."""
    if not CAPTIF_DIR.is_dir():
        pytest.skip(f"{REAL_DATA_SKIP} not found: no folder {CAPTIF_DIR}; {HOW_TO_RUN}")
    missing = [name for name in CAPTIF_FILE_NAMES if not (CAPTIF_DIR / name).is_file()]
    if missing:
        pytest.skip(f"{REAL_DATA_SKIP} incomplete: {', '.join(missing)} missing from {CAPTIF_DIR}; {HOW_TO_RUN}")
    return CAPTIF_DIR


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    """One line in the summary, even with -q and without -rs, when real-data tests skipped: a fresh
    clone otherwise reports only "40 skipped", and nothing says the README's claims about the real
    CAPTIF files went untested."""
    skipped = [report for report in terminalreporter.stats.get("skipped", [])
               if REAL_DATA_SKIP in str(getattr(report, "longrepr", ""))]
    if skipped:
        terminalreporter.write_line(f"{len(skipped)} real-data test(s) skipped: no CAPTIF profiles at {CAPTIF_DIR}; "
                                    f"{HOW_TO_RUN}", yellow=True)


@pytest.fixture(scope="session", params=CAPTIF_FILE_NAMES, ids=lambda name: name)
def captif_file(request: pytest.FixtureRequest, captif_dir: Path) -> Path:
    """Each real CAPTIF file in turn (a test taking it runs once per file); skips as captif_dir does."""
    return captif_dir / request.param


@pytest.fixture(scope="session")
def report_results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The synthetic archive's results, one run failing (report_pages.synthetic_results), processed
    once for every report test module."""
    from report_pages import synthetic_results

    return synthetic_results(tmp_path_factory.mktemp("report"))


@pytest.fixture(scope="session")
def report_built(report_results: Path, tmp_path_factory: pytest.TempPathFactory):
    """The report of ``report_results``, with the benchmark rows of report_pages.BENCHMARK."""
    import json

    from report_pages import BENCHMARK
    from roadtex.report import build_report

    benchmark = tmp_path_factory.mktemp("bench") / "rows.json"
    benchmark.write_text(json.dumps(BENCHMARK))
    return build_report(report_results, benchmark=benchmark)


@pytest.fixture(scope="session")
def report_drawn(report_results: Path):
    """The report's matplotlib figures of ``report_results``, drawn (so that every extent is known),
    closed afterwards."""
    from report_pages import BENCHMARK
    from roadtex.report import draw_figures
    from roadtex.report.data import load_results, pyplot

    plt = pyplot()
    figures, _ = draw_figures(load_results(report_results), BENCHMARK)
    for fig in figures.values():
        fig.canvas.draw()
    yield figures
    for fig in figures.values():
        plt.close(fig)
