"""The report and the main job: every figure present and drawn, the HTML well formed and self-contained;
legends off the data, figures numbered in document order, failed runs and each run's conditioning
listed, moduli in MPa and levels with their reference."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import polars as pl
import pytest
from matplotlib import image

from edited_results import as_written_by_a_job
from report_pages import WellFormed, column, parse, text_without_images
from roads import job_road
from roadtex.archive import ProcessingOptions, process
from roadtex.demo import write_synthetic_archive
from roadtex.report import FIGURES, SEED_FIGURES, build_report, octave_table
from roadtex.report.data import load_results, modulus_label, plain


@pytest.fixture(scope="module")
def results(report_results: Path) -> Path:
    """The synthetic archive plus one run whose file is empty (conftest, once per session)."""
    return report_results


@pytest.fixture(scope="module")
def report(report_built):
    return report_built


@pytest.fixture(scope="module")
def drawn(report_drawn):
    return report_drawn


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


def direct_octave_levels(loaded) -> pl.DataFrame:
    """Per run, E and octave band, the run's levels computed straight from its file, independently
    of the job's band path: read, conditioned and cut as the job does (as in test_archive_outputs'
    bit-for-bit test), the segments' readings joined by the job's road (monotone cubics, built with
    scipy in tests/python/roads.py; periodic: the last reading joins the first) onto the job's model
    grid (runs.parquet refine, model_dx), solved,
    binned straight into octaves (enveloped and pressure on the model grid, texture on the data's)
    and averaged over the segments in power."""
    from roadtex import contact_many
    from roadtex.profiles import read_profile
    from roadtex.spectra import band_levels

    options = loaded.options
    moduli = list(options["youngs_moduli"])
    rows = []
    for run in loaded.runs.iter_rows(named=True):
        profile = read_profile(run["path"]).conditioned(dx=run["dx_used"], spike_alpha=options["spike_alpha"])
        segments = profile.segments(options["segment_length"])
        count, n = segments.heights.shape
        k, model_dx = run["refine"], run["model_dx"]
        assert model_dx == pytest.approx(run["dx_used"] / k, rel=1e-12)
        model = job_road(segments.heights, k)
        batch = contact_many(model, model_dx, moduli, options["mean_pressure"], poisson=options["poisson"],
                             tol=run["tol_used"], max_iterations=options["max_iterations"], warm_start=True,
                             raise_on_nonconvergence=False)
        kwargs = {"kind": "octave", "periodic": True, "method": options["band_method"]}
        spectra = {
            "enveloped_level": band_levels(batch.envelope.reshape(count * len(moduli), -1), model_dx, **kwargs),
            "pressure_level": band_levels(batch.pressure.reshape(count * len(moduli), -1), model_dx,
                                          reference=1.0, **kwargs),
            "texture_level": band_levels(np.repeat(segments.heights, len(moduli), axis=0), segments.dx, **kwargs)}
        for kind, levels in spectra.items():
            power = np.mean(10.0 ** (levels.levels.reshape(count, len(moduli), -1) / 10.0), axis=0)
            for m, e in enumerate(moduli):
                rows += [(run["run_id"], float(e), band, kind, float(10.0 * np.log10(value)))
                         for band, value in zip(levels.bands["band"].to_list(), power[m])]
    return pl.DataFrame(rows, schema=["run_id", "youngs_modulus", "band", "column", "level"], orient="row").pivot(
        "column", index=["run_id", "youngs_modulus", "band"], values="level")


def test_octave_levels_sum_their_third_octaves(results: Path) -> None:
    """The report sums third octaves n-1, n, n+1 into octave n. By Parseval the octave holds exactly
    the power of its three third octaves, so the octave table of the third-octave job equals the
    octave levels computed straight from the files on the job's model grid (the same road and
    solves, another band path and another linear interpolation): this also checks that the job's
    contact levels are those of the model grid it states in runs.parquet."""
    loaded = load_results(results)
    assert (loaded.runs["refine"] > 1).all(), "the budget refines the 0.5 mm archive's model grid"
    from_thirds = octave_table(loaded)
    assert from_thirds.filter(pl.col("band") == 21).height > 0, "the 8 mm octave (band 21) is reported"
    keys = ["run_id", "youngs_modulus", "band"]
    joined = from_thirds.join(direct_octave_levels(loaded), on=keys, how="left", suffix="_direct")
    assert joined.height == from_thirds.height
    for kind in LEVELS:
        assert joined[f"{kind}_direct"].null_count() == 0, kind
        np.testing.assert_allclose(joined[kind], joined[f"{kind}_direct"], rtol=0, atol=1e-9, err_msg=kind)


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
    for kind in LEVELS:
        level, low, high = (joined[name].to_numpy() for name in (kind, f"{kind}_min", f"{kind}_max"))
        assert np.all((low - 1e-9 <= level) & (level <= high + 1e-9)), kind
        differ = high - low > 0.1
        assert np.all(level[differ] > joined[f"{kind}_db_mean"].to_numpy()[differ] + 1e-6), kind
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
    # The line runs were solved on the plan's model grid, and the report says which, and whether the
    # budget was met, as the job's outputs state it.
    plan = json.loads((tmp_path / "results" / "parameters.json").read_text())["plan"]
    runs = pl.read_parquet(tmp_path / "results" / "runs.parquet")
    lines = runs.filter(pl.col("run_id").is_in(segments.filter(pl.col("model") == "line")["run_id"].unique().implode())
                        & ~pl.col("run_id").is_in(segments.filter(pl.col("model") == "areal")["run_id"].unique().implode()))
    # each on its own readings and its own pilot group's model grid (one group a pavement here)
    group_k = {g["key"].split(" / ")[1]: g["refine"] for g in plan["group_errors"].values()}
    assert lines.height == 3 and min(group_k.values()) > 1
    pavements = dict(segments.select("run_id", "pavement").unique().iter_rows())
    assert lines["refine"].to_list() == [group_k[pavements[r]] for r in lines["run_id"]]
    assert lines["dx_used"].to_list() == lines["file_dx"].to_list()
    np.testing.assert_allclose(lines["model_dx"], lines["dx_used"] / lines["refine"], rtol=1e-12)
    text = text_without_images(tmp_path / "report" / "report.html")
    assert "Every line run was solved on its own readings, as its pilot group chose" in text
    for name, group in plan["group_errors"].items():
        assert f"{name}: dx = {plain(group['data_dx'] * 1e3)} mm, k = {group['refine']} (model grid" in text
    # the verdict is every run's, the surface runs' own included (the plan's is its line pilots')
    every_run = pl.read_parquet(tmp_path / "results" / "runs.parquet")["within_budget"].drop_nulls().all()
    assert f"Within budget: {'yes' if every_run else 'no'}" in text
    # Run again on the same output: nothing to recompute.
    again = subprocess.run([sys.executable, "-m", "roadtex.cli", "demo", "--out", str(tmp_path), "--runs", "1",
                            "--run-length", "1.0", "--quiet"], capture_output=True, text=True, timeout=600)
    assert again.returncode == 0 and "0 processed, 6 already done" in again.stdout


# --------------------------------------------------------------------------------------------------
# Issue 14: legends, numbering, failed runs, conditioning facts, units and level references
# --------------------------------------------------------------------------------------------------


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
    as_written_by_a_job(copy)
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
    for heading in ("file dx (mm)", "dx (mm)", "k (model grid dx / k)", "model dx (mm)", "trimmed (mm)",
                    "reference plates", "drop-outs (%)", "spikes (%)", "outliers (%)", "warnings", "MPD (mm)",
                    "MPD valid", "valid MPD baselines"):
        assert heading in table["header"], heading
    order = np.argsort(column(table, "run_id"))
    shown = {h: [column(table, h)[i] for i in order] for h in table["header"]}
    assert shown["run_id"] == runs["run_id"].to_list()
    assert shown["dx (mm)"] == ["0.5"] * runs.height  # the archive is sampled at 0.5 mm
    assert shown["k (model grid dx / k)"] == [str(k) for k in runs["refine"]] and (runs["refine"] > 1).all()
    assert shown["model dx (mm)"] == [plain(0.5 / k) for k in runs["refine"]]
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
    as_written_by_a_job(copy)
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


def test_a_figure_is_laid_out_once_and_its_svg_keeps_the_pngs_layout(tmp_path: Path) -> None:
    """save_png_and_svg: the PNG's save lays the figure out (a layout pass, then the draw), the SVG's
    draws once with that layout, no second pass: three draws in all; the SVG's axes sit where the
    PNG's layout put them."""
    from matplotlib.figure import Figure

    from roadtex.report.data import pyplot, save_png_and_svg

    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(6, 3), layout="constrained")
    for ax in axes:
        ax.plot([0, 1], [0, 1], label="a line with a long label")
        ax.set_ylabel("level (dB re 1e-6 m)")
    fig.legend(loc="outside right upper")
    draws: list[str] = []
    original = Figure.draw

    def counting(self: Figure, renderer: object) -> None:
        draws.append(type(renderer).__name__)
        original(self, renderer)

    Figure.draw = counting   # type: ignore[method-assign]
    try:
        png = save_png_and_svg(fig, tmp_path / "figure.svg")
    finally:
        Figure.draw = original   # type: ignore[method-assign]
    plt.close(fig)
    assert len(draws) == 3, draws
    assert png.startswith(b"\x89PNG") and (tmp_path / "figure.svg").read_text().lstrip().startswith("<?xml")
    assert fig.get_layout_engine() is None
    laid_out = [ax.get_position().bounds for ax in axes]
    assert laid_out[0][0] > 0.05 and laid_out[1][0] + laid_out[1][2] < 0.95   # moved by the layout, legend outside
