"""What the report tests share: an HTML checker and table reader, the synthetic archive's
results (one run failing at the read stage) and the benchmark rows the report is given. Built
once per session (conftest: report_results, report_built, report_drawn)."""

from __future__ import annotations

import re
from html.parser import HTMLParser
from pathlib import Path

import polars as pl

from roadtex.archive import ProcessingOptions, process
from roadtex.demo import write_synthetic_archive

VOID = {"meta", "img", "br", "hr", "link", "input"}


class WellFormed(HTMLParser):
    """Checks that every element closes in order and collects the figures and images."""

    def __init__(self) -> None:
        super().__init__()
        self.stack: list[str] = []
        self.problems: list[str] = []
        self.figures: list[str] = []
        self.images: list[str] = []

    def handle_starttag(self, tag, attrs):
        attributes = dict(attrs)
        if tag == "figure":
            self.figures.append(attributes.get("id", ""))
        if tag == "img":
            self.images.append(attributes.get("src", ""))
        if tag not in VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag, attrs):
        self.handle_starttag(tag, attrs)
        if tag not in VOID:
            self.stack.pop()

    def handle_endtag(self, tag):
        if tag in VOID:
            return
        if not self.stack or self.stack[-1] != tag:
            self.problems.append(f"</{tag}> closes <{self.stack[-1] if self.stack else 'nothing'}>")
        else:
            self.stack.pop()


def synthetic_results(folder: Path) -> Path:
    """The synthetic archive plus one run whose file is empty: it fails at the read stage."""
    manifest = write_synthetic_archive(folder / "archive", runs_per_kind=2, run_length=1.0)
    (manifest.parent / "broken_001.csv").write_text("")
    table = pl.read_csv(manifest)
    broken = {**table.row(0, named=True), "path": "broken_001.csv", "run_id": "broken_001", "site": "broken"}
    with_broken = manifest.parent / "with_broken.csv"
    pl.concat([table, pl.DataFrame([broken], schema=table.schema)]).write_csv(with_broken)
    options = ProcessingOptions(youngs_moduli=(1e6, 5e6), segment_length=0.25, tol=1e-8)
    summary = process(with_broken, folder / "results", options, quiet=True)
    assert summary.failed == 1 and summary.processed == 6
    return folder / "results"


BENCHMARK = {"meta": {}, "rows": [
    {"case": "westergaard", "solver": solver, "time_s": t * scale, "l1_error": e / scale}
    for solver, t in (("roadtex-element", 0.01), ("tamaas", 0.2)) for scale, e in ((1, 1e-5), (4, 2e-6), (16, 3e-7))]}


class Tables(HTMLParser):
    """The HTML's tables by class (header and rows of cell texts) and its figure captions."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: dict[str, dict[str, list]] = {}
        self.captions: list[str] = []
        self.current: dict[str, list] | None = None
        self.row: list[str] | None = None
        self.text: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self.current = self.tables.setdefault(dict(attrs).get("class") or "", {"header": [], "rows": []})
        elif tag == "tr":
            self.row = []
        elif tag in ("td", "th", "figcaption"):
            self.text = []

    def handle_data(self, data):
        if self.text is not None:
            self.text.append(data)

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self.row is not None and self.text is not None:
            self.row.append("".join(self.text))
            self.text = None
        elif tag == "figcaption" and self.text is not None:
            self.captions.append("".join(self.text))
            self.text = None
        elif tag == "tr" and self.current is not None and self.row is not None:
            if self.current["header"]:
                self.current["rows"].append(self.row)
            else:
                self.current["header"] = self.row
            self.row = None
        elif tag == "table":
            self.current = None


def parse(path: Path) -> Tables:
    parser = Tables()
    parser.feed(path.read_text(encoding="utf-8"))
    return parser


def column(table: dict[str, list], heading: str) -> list[str]:
    index = table["header"].index(heading)
    return [row[index] for row in table["rows"]]


def text_without_images(path: Path) -> str:
    return re.sub(r'src="data:[^"]*"', "", path.read_text(encoding="utf-8"))

