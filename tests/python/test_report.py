"""The report and the main job: every figure present and drawn, the HTML well formed and self-contained."""

from __future__ import annotations

import json
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
from roadtex.report import FIGURES, build_report, octave_table
from roadtex.report.data import load_results

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
    folder = tmp_path_factory.mktemp("report")
    manifest = write_synthetic_archive(folder / "archive", runs_per_kind=2, run_length=1.0)
    options = ProcessingOptions(youngs_moduli=(1e6, 5e6), segment_length=0.25, tol=1e-8)
    process(manifest, folder / "results", options, quiet=True)
    return folder / "results"


@pytest.fixture(scope="module")
def report(results: Path, tmp_path_factory: pytest.TempPathFactory):
    benchmark = tmp_path_factory.mktemp("bench") / "rows.json"
    rows = [{"case": "westergaard", "solver": solver, "time_s": t * scale, "l1_error": e / scale}
            for solver, t in (("roadtex-element", 0.01), ("tamaas", 0.2)) for scale, e in ((1, 1e-5), (4, 2e-6), (16, 3e-7))]
    benchmark.write_text(json.dumps({"meta": {}, "rows": rows}))
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
    assert "3 processed" in done.stdout and "report with" in done.stdout
    assert (tmp_path / "report" / "report.html").stat().st_size > 50_000
    segments = pl.read_parquet(tmp_path / "results" / "segments.parquet")
    assert set(segments["pavement"].unique()) == {"cement_concrete", "dense_asphalt", "porous_asphalt"}
    # Run again on the same output: nothing to recompute.
    again = subprocess.run([sys.executable, "-m", "roadtex.cli", "demo", "--out", str(tmp_path), "--runs", "1",
                            "--run-length", "1.0", "--quiet"], capture_output=True, text=True, timeout=600)
    assert again.returncode == 0 and "0 processed, 3 already done" in again.stdout
