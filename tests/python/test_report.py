"""The report and the main job: every figure present and drawn, the HTML well formed and self-contained;
legends off the data, figures numbered in document order, failed runs and each run's conditioning
listed, moduli in MPa and levels with their reference."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import polars as pl
import pytest
from matplotlib import image

from roadtex.archive import ProcessingOptions, process
from roadtex.demo import write_synthetic_archive
from roadtex.report import FIGURES, SEED_FIGURES, build_report, draw_figures, octave_table
from roadtex.report.data import load_results, modulus_label, plain, pyplot

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


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The synthetic archive plus one run whose file is empty: it fails at the read stage."""
    folder = tmp_path_factory.mktemp("report")
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


@pytest.fixture(scope="module")
def report(results: Path, tmp_path_factory: pytest.TempPathFactory):
    benchmark = tmp_path_factory.mktemp("bench") / "rows.json"
    benchmark.write_text(json.dumps(BENCHMARK))
    return build_report(results, benchmark=benchmark)


def test_html_is_well_formed_self_contained_and_has_every_figure(report) -> None:
    text = report.html.read_text(encoding="utf-8")
    parser = WellFormed()
    parser.feed(text)
    parser.close()
    assert parser.problems == [] and parser.stack == []
    assert parser.figures == list(FIGURES)
    assert all(src.startswith("data:image/png;base64,") for src in parser.images)
    assert len(parser.images) == len(FIGURES)
    assert "http://" not in text.replace("http://www.w3.org", "") and "https://" not in text


def test_every_figure_is_written_as_png_and_svg_and_is_not_blank(report) -> None:
    assert set(report.figures) == set(FIGURES)
    for name, (png, svg) in report.figures.items():
        pixels = image.imread(png)[::2, ::2, :3]
        inked = np.mean(np.any(pixels < 0.9, axis=-1))
        assert inked > 0.02, f"{name} looks blank ({inked:.3%} of pixels drawn)"
        colours = np.unique((pixels.reshape(-1, 3) * 255).astype(np.uint8), axis=0)
        assert len(colours) > 8, f"{name} has almost no colours: no data drawn"
        assert svg.read_text().count("<path") > 10, f"{name}.svg holds almost no drawn paths"


def test_each_figure_with_data_panels_has_data(report, results: Path) -> None:
    """Every pavement of the archive appears in the spectra and every E in the regressions."""
    text = report.html.read_text(encoding="utf-8")
    for kind in ("cement_concrete", "dense_asphalt", "porous_asphalt"):
        assert kind in text
    octaves = octave_table(load_results(results))
    assert set(octaves["youngs_modulus"].unique()) == {1e6, 5e6}
    assert octaves.filter(pl.col("pressure_level").is_finite()).height > 0


@pytest.fixture(scope="module")
def octave_results(results: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The same archive and options as ``results``, with the job's band levels in octaves."""
    folder = tmp_path_factory.mktemp("octaves")
    manifest = write_synthetic_archive(folder / "archive", runs_per_kind=2, run_length=1.0)
    options = ProcessingOptions(youngs_moduli=(1e6, 5e6), segment_length=0.25, tol=1e-8, band_kind="octave")
    process(manifest, folder / "results", options, quiet=True)
    return folder / "results"


LEVELS = ("enveloped_level", "pressure_level", "texture_level")


def test_octave_levels_sum_their_third_octaves(results: Path, octave_results: Path) -> None:
    """The report sums third octaves n-1, n, n+1 into octave n. By Parseval the octave holds exactly
    the power of its three third octaves, so the octave table of the third-octave job equals that of
    a job whose spectra were binned straight into octaves (the same solves, another band path)."""
    from_thirds = octave_table(load_results(results))
    from_octaves = octave_table(load_results(octave_results))
    assert from_thirds.filter(pl.col("band") == 21).height > 0, "the 8 mm octave (band 21) is reported"
    keys = ["run_id", "youngs_modulus", "band"]
    joined = from_thirds.join(from_octaves, on=keys, how="full", suffix="_direct")
    assert joined.height == from_thirds.height == from_octaves.height
    for column in LEVELS:
        np.testing.assert_allclose(joined[column], joined[f"{column}_direct"], rtol=0, atol=1e-9, err_msg=column)


def test_run_levels_are_energetic_means_of_the_segments(octave_results: Path) -> None:
    """Each run's octave level averages its segments' levels in power: it lies between the lowest
    and the highest segment, and above their mean in dB (Jensen: the mean of 10^(L/10) exceeds
    10^(mean L / 10)) wherever the segments differ."""
    loaded = load_results(octave_results)
    table = octave_table(loaded)
    per_segment = loaded.bands.group_by("run_id", "youngs_modulus", "band").agg(
        *[pl.col(c).min().alias(f"{c}_min") for c in LEVELS], *[pl.col(c).max().alias(f"{c}_max") for c in LEVELS],
        *[pl.col(c).mean().alias(f"{c}_db_mean") for c in LEVELS], pl.len().alias("segments"))
    joined = table.join(per_segment, on=["run_id", "youngs_modulus", "band"], how="left")
    assert joined.height == table.height and (joined["segments"] >= 2).all()
    spread = 0
    for column in LEVELS:
        level, low, high = (joined[name].to_numpy() for name in (column, f"{column}_min", f"{column}_max"))
        assert np.all((low - 1e-9 <= level) & (level <= high + 1e-9)), column
        differ = high - low > 0.1
        assert np.all(level[differ] > joined[f"{column}_db_mean"].to_numpy()[differ] + 1e-6), column
        spread += int(differ.sum())
    assert spread > 0, "no run whose segments differ: the Jensen check would be empty"


def test_report_refuses_a_folder_that_is_not_results(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="not a roadtex results folder"):
        build_report(tmp_path)


def test_main_job_runs_end_to_end(tmp_path: Path) -> None:
    """`roadtex demo`, the README's main-job command, on a small built-in archive."""
    done = subprocess.run([sys.executable, "-m", "roadtex.cli", "demo", "--out", str(tmp_path), "--runs", "1",
                           "--run-length", "1.0", "--quiet"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "6 processed" in done.stdout and "report with" in done.stdout   # 3 line runs, 3 surface runs
    assert (tmp_path / "report" / "report.html").stat().st_size > 50_000
    assert "No failed runs" in (tmp_path / "report" / "report.html").read_text(encoding="utf-8")
    segments = pl.read_parquet(tmp_path / "results" / "segments.parquet")
    assert set(segments["pavement"].unique()) == {"cement_concrete", "dense_asphalt", "porous_asphalt"}
    # Run again on the same output: nothing to recompute.
    again = subprocess.run([sys.executable, "-m", "roadtex.cli", "demo", "--out", str(tmp_path), "--runs", "1",
                            "--run-length", "1.0", "--quiet"], capture_output=True, text=True, timeout=600)
    assert again.returncode == 0 and "0 processed, 6 already done" in again.stdout


# --------------------------------------------------------------------------------------------------
# Issue 14: legends, numbering, failed runs, conditioning facts, units and level references
# --------------------------------------------------------------------------------------------------

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


@pytest.fixture(scope="module")
def drawn(results: Path):
    """The report's matplotlib figures, drawn (so that every extent is known), closed afterwards."""
    plt = pyplot()
    figures, _ = draw_figures(load_results(results), BENCHMARK)
    for fig in figures.values():
        fig.canvas.draw()
    yield figures
    for fig in figures.values():
        plt.close(fig)


def test_no_legend_lies_over_any_axes(drawn) -> None:
    """Figures 2.1, 4.1 and 4.2 had their legend over the curves: now every figure has its legend,
    and none overlaps the data area of any of its axes (the legend sits outside them)."""
    assert set(drawn) == set(FIGURES)
    for name, fig in drawn.items():
        legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
        assert legends, f"{name} has no legend"
        renderer = fig.canvas.get_renderer()
        for legend in legends:
            box = legend.get_window_extent(renderer)
            for ax in fig.axes:
                if ax.get_visible():
                    assert not box.overlaps(ax.get_window_extent(renderer)), f"{name}: legend over {ax.get_title()!r}"


def test_legends_name_moduli_in_mpa(drawn) -> None:
    texts = [t.get_text() for fig in drawn.values() for legend in fig.legends for t in legend.get_texts()]
    assert "E = 1 MPa" in texts and "E = 5 MPa" in texts
    assert not any("e+" in t for t in texts), texts
    assert modulus_label(2.5e6) == "E = 2.5 MPa" and modulus_label(1e6) == "E = 1 MPa"
    assert plain(2.5e6) == "2500000" and plain(0.0375) == "0.0375" and plain(float("nan")) == "n/a"


def test_every_level_axis_states_its_reference(drawn) -> None:
    """A level is meaningless without its reference: texture in dB re 1 µm, pressure in dB re 1 Pa;
    only a difference of two levels (same reference) is plain dB."""
    labels = [label for fig in drawn.values() for ax in fig.axes for label in (ax.get_xlabel(), ax.get_ylabel())]
    levels = [label for label in labels if "level" in label]
    assert any("texture" in label for label in levels) and any("pressure" in label for label in levels)
    for label in levels:
        if "−" in label:  # enveloped − original: a level difference
            assert "(dB)" in label
        elif "pressure" in label:
            assert "dB re 1 Pa" in label, label
        else:
            assert "texture" in label and "dB re 1 µm" in label, label


def test_each_seed_figure_is_claimed_by_one_figure_only() -> None:
    """The INRETS report has one figure 4.4: a new figure (the areal model's) never claims it."""
    assert len(set(SEED_FIGURES.values())) == len(SEED_FIGURES), SEED_FIGURES
    assert "line_vs_areal" not in SEED_FIGURES


def test_figures_are_numbered_in_document_order(report) -> None:
    """Figure 1, 2, 3 ... in the order they appear, each naming the seed figure it reproduces;
    the number of a seed figure (4.1) is never used as the document's own."""
    captions = parse(report.html).captions
    assert len(captions) == len(FIGURES)
    numbers = [int(re.match(r"Figure (\d+): ", c).group(1)) for c in captions]
    assert numbers == list(range(1, len(FIGURES) + 1))
    for caption, name in zip(captions, FIGURES):
        if name in SEED_FIGURES:
            assert f"reproduces figure {SEED_FIGURES[name]} of the INRETS report" in caption
        assert not re.search(r"Figure \d+\.\d", caption), caption
    envelopes = list(FIGURES).index("envelopes") + 1
    assert f"profiles of Figure {envelopes}" in captions[list(FIGURES).index("pressures")]
    for number, (name, (png, svg)) in enumerate(report.figures.items(), start=1):
        assert png.name == f"figure_{number}_{name}.png" and svg.name == f"figure_{number}_{name}.svg"


def test_failed_runs_are_listed(report, results: Path) -> None:
    """The run whose file is empty is in the report: run id, stage, error type, message and file."""
    errors = pl.read_parquet(results / "errors.parquet")
    assert errors["run_id"].to_list() == ["broken_001"]
    tables = parse(report.html).tables
    failures = tables["failures"]
    assert failures["header"] == ["run_id", "stage", "error type", "message", "file"]
    assert failures["rows"] == [[errors["run_id"][0], errors["stage"][0], errors["error_type"][0],
                                 errors["message"][0], errors["path"][0]]]
    assert failures["rows"][0][1] == "read" and failures["rows"][0][4].endswith("broken_001.csv")
    assert "1 run(s) failed" in report.html.read_text(encoding="utf-8")
    assert "broken_001" not in column(tables["runs"], "run_id")


@pytest.fixture(scope="module")
def altered(results: Path, tmp_path_factory: pytest.TempPathFactory) -> dict:
    """A copy of ``results`` as another job could leave it, reported once: no failure on record,
    the first run's MPD null (no valid baseline), and one reported band's pressure level null."""
    copy = tmp_path_factory.mktemp("altered") / "results"
    shutil.copytree(results, copy, ignore=shutil.ignore_patterns("report"))
    pl.read_parquet(results / "errors.parquet").head(0).write_parquet(copy / "errors.parquet")
    runs = pl.read_parquet(results / "runs.parquet")
    first = runs["run_id"][0]
    is_first = pl.col("run_id") == first
    runs.with_columns(pl.when(is_first).then(None).otherwise(pl.col("mpd")).alias("mpd"),
                      pl.when(is_first).then(False).otherwise(pl.col("mpd_valid")).alias("mpd_valid"),
                      ).write_parquet(copy / "runs.parquet")
    bands = pl.read_parquet(results / "bands.parquet")
    band = bands.filter(pl.col("reported") & (pl.col("band") == 21) & (pl.col("segment") == 0)).row(0, named=True)
    hit = ((pl.col("run_id") == band["run_id"]) & (pl.col("segment") == 0) & (pl.col("band") == 21)
           & (pl.col("youngs_modulus") == band["youngs_modulus"]))
    bands.with_columns(pl.when(hit).then(None).otherwise(pl.col("pressure_level")).alias("pressure_level")) \
        .write_parquet(copy / "bands.parquet")
    return {"folder": copy, "report": build_report(copy), "first": first, "band": band}


def test_no_failure_is_said_in_a_line(altered: dict) -> None:
    text = altered["report"].html.read_text(encoding="utf-8")
    assert "No failed runs" in text and "failures" not in parse(altered["report"].html).tables
    assert "0 run(s) failed" in text


def test_each_runs_conditioning_is_shown(report, results: Path) -> None:
    """runs.parquet's conditioning facts, per run, in report units: dx in mm, trimmed length in mm,
    shares in %, MPD in mm with its validity and valid/all baselines."""
    runs = pl.read_parquet(results / "runs.parquet").sort("run_id")
    table = parse(report.html).tables["conditioning"]
    for heading in ("file dx (mm)", "dx (mm)", "trimmed (mm)", "reference plates", "drop-outs (%)", "spikes (%)",
                    "outliers (%)", "warnings", "MPD (mm)", "MPD valid", "valid MPD baselines"):
        assert heading in table["header"], heading
    order = np.argsort(column(table, "run_id"))
    shown = {h: [column(table, h)[i] for i in order] for h in table["header"]}
    assert shown["run_id"] == runs["run_id"].to_list()
    assert shown["dx (mm)"] == ["0.5"] * runs.height  # the archive is sampled at 0.5 mm
    assert shown["valid MPD baselines"] == [f"{v}/{n}" for v, n in runs.select("mpd_valid_baselines", "mpd_baselines").iter_rows()]
    assert shown["MPD valid"] == ["yes" if v else "no" for v in runs["mpd_valid"]]
    np.testing.assert_allclose([float(v) for v in shown["MPD (mm)"]], runs["mpd"].to_numpy() * 1e3, rtol=5e-3)
    # the main table says it too: an MPD from too few valid baselines is not read as a valid one
    main = parse(report.html).tables["runs"]
    validity = dict(zip(column(main, "run_id"), column(main, "MPD valid")))
    assert validity == {r: "yes" if v else "no" for r, v in runs.select("run_id", "mpd_valid").iter_rows()}
    np.testing.assert_allclose([float(v) for v in shown["spikes (%)"]], runs["spike_fraction"].to_numpy() * 100,
                               rtol=5e-3, atol=1e-12)


def test_mpd_without_a_value_is_n_a(altered: dict) -> None:
    """A run without a valid MPD baseline has MPD null in runs.parquet: the report writes n/a, in
    both tables, and never an empty cell or 'nan'."""
    tables = parse(altered["report"].html).tables
    for name in ("runs", "conditioning"):
        mpd = dict(zip(column(tables[name], "run_id"), column(tables[name], "MPD (mm)")))
        assert mpd[altered["first"]] == "n/a"
        assert all(v not in ("", "nan", "n/a") for run, v in mpd.items() if run != altered["first"])


def test_html_writes_moduli_and_pressures_in_mpa_and_levels_with_reference(report) -> None:
    text = text_without_images(report.html)
    assert not re.search(r"\d[eE][+-]\d", text), "a number written with an exponent"
    assert "E = 1, 5 MPa, P = 0.2 MPa" in text
    tables = parse(report.html).tables
    assert "contact % (E = 1 MPa)" in tables["runs"]["header"] and "contact % (E = 5 MPa)" in tables["runs"]["header"]
    assert "mean texture band level (dB re 1 µm)" in tables["runs"]["header"]
    regressions = tables["regressions"]
    assert "intercept (dB re 1 Pa)" in regressions["header"]
    assert set(column(regressions, "E (MPa)")) == {"1", "5"}
    for table in tables.values():
        for heading in table["header"]:
            assert "level" not in heading or "dB re 1" in heading, heading


def test_unreported_bands_and_null_levels(results: Path, altered: dict, tmp_path: Path) -> None:
    """bands.parquet keeps every band with ``reported``; the report reads only the reported ones. A
    null level drops its octave for that segment (never a two-part power sum): the octave table is
    then the one without that segment's octave, and the report is still drawn."""
    every = pl.read_parquet(results / "bands.parquet")
    assert {"reported", "reason"} <= set(every.columns) and not every["reported"].all()
    assert load_results(results).bands["reported"].all()

    band = altered["band"]
    with_null = octave_table(load_results(altered["folder"]))
    octave = ((pl.col("run_id") == band["run_id"]) & (pl.col("segment") == 0) & pl.col("band").is_in([20, 21, 22])
              & (pl.col("youngs_modulus") == band["youngs_modulus"]))
    copy = tmp_path / "results"
    shutil.copytree(altered["folder"], copy, ignore=shutil.ignore_patterns("report"))
    every.filter(~octave).write_parquet(copy / "bands.parquet")
    without = octave_table(load_results(copy))
    key = ["run_id", "youngs_modulus", "band"]
    joined = with_null.join(without, on=key, suffix="_without")
    assert joined.height == with_null.height == without.height
    pick = joined.filter((pl.col("run_id") == band["run_id"]) & (pl.col("band") == 21)
                         & (pl.col("youngs_modulus") == band["youngs_modulus"]))
    assert pick.height == 1 and np.isfinite(pick["pressure_level"][0])
    np.testing.assert_allclose(joined["pressure_level"], joined["pressure_level_without"], rtol=0, atol=1e-9)
    full = octave_table(load_results(results)).join(with_null, on=key, suffix="_null")
    changed = full.filter((pl.col("pressure_level") - pl.col("pressure_level_null")).abs() > 1e-9)
    assert changed.select("run_id", "band").rows() == [(band["run_id"], 21)]
    assert altered["report"].figures["pressure_vs_texture"][0].stat().st_size > 10_000


# --------------------------------------------------------------------------------------------------
# Issue 15: speed against error of the pilot's settings, and the numerical error of every band
# --------------------------------------------------------------------------------------------------

def worst_in_budget(pilot: pl.DataFrame) -> pl.DataFrame:
    """Per group and setting, the largest level error over the budget bands and the time per km."""
    return (pilot.filter(pl.col("in_budget")).group_by("group", "dx", "tol")
            .agg(pl.col("level_error_db").max().alias("worst"), (pl.col("seconds_per_metre").first() * 1e3).alias("s_km"),
                 pl.col("chosen").first(), pl.col("reference").first()))


@pytest.fixture(scope="module")
def budget_off(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The synthetic archive processed with the error budget off, and its report."""
    folder = tmp_path_factory.mktemp("budget_off")
    manifest = write_synthetic_archive(folder / "archive", runs_per_kind=1, run_length=1.0)
    options = ProcessingOptions(youngs_moduli=(1e6,), segment_length=0.25, tol=1e-8, error_budget_db=None)
    process(manifest, folder / "results", options, quiet=True)
    return {"folder": folder / "results", "report": build_report(folder / "results")}


@pytest.fixture(scope="module")
def without_pilot(results: Path, tmp_path_factory: pytest.TempPathFactory) -> dict:
    """``results`` as a roadtex before the error budget left it: no pilot.parquet."""
    copy = tmp_path_factory.mktemp("no_pilot") / "results"
    shutil.copytree(results, copy, ignore=shutil.ignore_patterns("report", "pilot.parquet"))
    return {"folder": copy, "report": build_report(copy)}


def speed_figure_text(fig) -> str:
    return " ".join(t.get_text() for ax in fig.axes for t in ax.texts)


def test_speed_against_error_figure_is_always_in_the_report(report, results: Path, budget_off: dict,
                                                            without_pilot: dict) -> None:
    """With the budget on the figure shows the pilot's settings; with it off, and for a folder without
    pilot.parquet, it is still there and says why it has no points."""
    assert len(pl.read_parquet(results / "pilot.parquet")) > 0
    assert pl.read_parquet(budget_off["folder"] / "pilot.parquet").height == 0
    for built, says in ((report, None), (budget_off["report"], "error budget off"),
                        (without_pilot["report"], "No pilot was recorded")):
        png, svg = built.figures["setting_speed_vs_error"]
        assert png.stat().st_size > 5_000 and svg.exists()
        parsed = WellFormed()
        parsed.feed(built.html.read_text(encoding="utf-8"))
        assert "setting_speed_vs_error" in parsed.figures
        caption = next(c for c in parse(built.html).captions if "Speed against error of the processed archive" in c)
        if says is None:
            assert "No pilot" not in caption
        else:
            assert says in caption
    plt = pyplot()
    for folder, says in ((budget_off["folder"], "error budget off"), (without_pilot["folder"], "No pilot was recorded")):
        figures, _ = draw_figures(load_results(folder))
        fig = figures["setting_speed_vs_error"]
        assert says in speed_figure_text(fig)
        assert not any(len(c.get_offsets()) for ax in fig.axes for c in ax.collections)
        for f in figures.values():
            plt.close(f)


def test_chosen_point_is_plotted_at_the_chosen_setting(drawn, results: Path) -> None:
    """One panel per pilot group; its points are every setting the pilot evaluated, at (worst level
    error over the budget bands, seconds per metre x 1000) read from pilot.parquet; the starred point
    is the chosen setting's; the budget is the dashed line; the reference is labelled."""
    pilot = pl.read_parquet(results / "pilot.parquet")
    settings = worst_in_budget(pilot)
    fig = drawn["setting_speed_vs_error"]
    panels = {ax.get_title().replace("\n", " "): ax for ax in fig.axes if ax.get_visible()}
    groups = pilot["group"].unique().to_list()
    assert len(panels) == len(groups) >= 3
    budget = json.loads((results / "parameters.json").read_text())["plan"]["budget_db"]
    for group in groups:
        ax = next(a for title, a in panels.items() if group in title)
        mine = settings.filter(pl.col("group") == group)
        chosen = mine.filter(pl.col("chosen"))
        assert chosen.height == 1
        stars = [c for c in ax.collections if c.get_gid() == "chosen"]
        assert len(stars) == 1
        np.testing.assert_allclose(stars[0].get_offsets(), [[chosen["worst"][0], chosen["s_km"][0]]], rtol=1e-12)
        plotted = np.concatenate([np.column_stack(line.get_data()) for line in ax.lines if line.get_marker() == "o"])
        expected = mine.select("worst", "s_km").to_numpy()
        assert len(plotted) == len(expected)
        assert sorted(map(tuple, np.round(plotted, 12))) == sorted(map(tuple, np.round(expected, 12)))
        assert [line.get_xdata()[0] for line in ax.lines if line.get_linestyle() == "--"] == [budget]
        assert any(t.get_text().endswith(" finest") for t in ax.texts)
        assert not any("reference" in t.get_text() for t in ax.texts)   # the finest setting has its own error
        assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    assert "s/km" in fig.axes[0].get_ylabel()


def test_band_error_table_lists_every_band_of_the_plan(report, results: Path) -> None:
    """Every band of the plan with its label, whether the budget applies, the plan's error and each
    group's error at its chosen setting (pilot.parquet); the line with budget, dx, tol, verdict,
    speed-up and pilot time; the budget not met said plainly, with its floor."""
    plan = json.loads((results / "parameters.json").read_text())["plan"]
    pilot = pl.read_parquet(results / "pilot.parquet")
    table = parse(report.html).tables["band-errors"]
    bands = sorted(int(b) for b in plan["band_error_db"])
    facts = pilot.group_by("band").agg(pl.col("label").first(), pl.col("in_budget").first()).sort("band")
    facts = facts.filter(pl.col("band").is_in(bands))
    assert column(table, "band (mm)") == facts["label"].to_list() and len(bands) == len(table["rows"])
    assert column(table, "in budget") == ["yes" if v else "no" for v in facts["in_budget"]]
    shown = [float(v) for v in column(table, "estimated error at the job's setting (dB)")]
    np.testing.assert_allclose(shown, [plan["band_error_db"][str(b)] for b in bands], rtol=5e-3)
    for group in pilot["group"].unique().to_list():
        at_choice = pilot.filter(pl.col("chosen") & (pl.col("group") == group) & pl.col("band").is_in(bands)).sort("band")
        values = [float(v) for v in column(table, f"at the chosen setting of {group} (dB)")]
        np.testing.assert_allclose(values, at_choice["level_error_db"].to_numpy(), rtol=5e-3)
    text = text_without_images(report.html)
    assert f"dx = {plain(plan['dx'] * 1e3)} mm and tol = 10⁻⁸" in text
    assert f"{plain(plan['speedup'])} times less solver work" in text
    assert f"the pilots took {plain(plan['pilot_seconds'])} s" in text
    assert f"Error budget {plain(plan['budget_db'])} dB" in text
    # The synthetic archive's 0.5 mm sampling cannot meet 0.2 dB: the floor is the group whose best
    # setting is worst.
    assert plan["within_budget"] is False
    floor = worst_in_budget(pilot).group_by("group").agg(pl.col("worst").min())["worst"].max()
    assert "Within budget: no" in text and "could not be met at the data's sampling" in text
    assert f"the floor, is {plain(floor)} dB" in text and floor > plan["budget_db"]


def test_within_budget_is_said_without_a_floor(results: Path, tmp_path: Path) -> None:
    copy = tmp_path / "results"
    shutil.copytree(results, copy, ignore=shutil.ignore_patterns("report"))
    parameters = json.loads((copy / "parameters.json").read_text())
    parameters["plan"]["within_budget"] = True
    (copy / "parameters.json").write_text(json.dumps(parameters))
    text = text_without_images(build_report(copy).html)
    assert "Within budget: yes" in text and "could not be met" not in text


def test_budget_off_and_missing_pilot_are_said(budget_off: dict, without_pilot: dict, results: Path) -> None:
    """Budget off: no estimate to tabulate, and the section says so with the setting used. No
    pilot.parquet: the plan's bands are still listed (labels from bands.parquet), and the section
    says no pilot was recorded."""
    off = parse(budget_off["report"].html)
    assert "band-errors" not in off.tables
    assert "the job ran with the error budget off (every run solved at dx = 0.5 mm, tol = 10⁻⁸)" in \
        text_without_images(budget_off["report"].html)
    runs = pl.read_parquet(budget_off["folder"] / "runs.parquet")
    assert runs["worst_level_error_db"].is_null().all()
    assert column(off.tables["conditioning"], "tol") == ["10⁻⁸"] * runs.height

    plan = json.loads((results / "parameters.json").read_text())["plan"]
    missing = parse(without_pilot["report"].html)
    table = missing.tables["band-errors"]
    assert len(table["rows"]) == len(plan["band_error_db"])
    assert set(column(table, "in budget")) == {"n/a"}
    assert not any(h.startswith("at the chosen setting") for h in table["header"])
    assert "No pilot was recorded" in text_without_images(without_pilot["report"].html)
