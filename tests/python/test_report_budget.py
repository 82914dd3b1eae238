"""The report's account of the error budget (issues 15 and 34): the speed against error of every
(dx, k, tol) setting the pilots evaluated, the numerical error of every band, what the data's
sampling cannot tell (the interpolant spread, sampling-limited bands, hatched in the contact
spectra), the budget off, missed, or without a pilot."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from report_pages import WellFormed, column, parse, text_without_images
from roadtex.archive import ProcessingOptions, process
from roadtex.budget.study import REFERENCE_TOL
from roadtex.demo import write_synthetic_archive
from roadtex.report import build_report, draw_figures
from roadtex.report.data import load_results, plain, pyplot


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


def worst_in_budget(pilot: pl.DataFrame) -> pl.DataFrame:
    """Per group and setting, the largest level error over the budget bands and the time per km."""
    return (pilot.filter(pl.col("in_budget")).group_by("group", "dx", "refine", "tol")
            .agg(pl.col("level_error_db").max().alias("worst"), (pl.col("seconds_per_metre").first() * 1e3).alias("s_km"),
                 pl.col("chosen").first(), pl.col("reference").first()))


def setting_said(dx: float, k: int, tol: str) -> str:
    """How the report labels a setting by its model grid (dx in m)."""
    return f"dx {plain(dx * 1e3)} mm, k {k} (model {plain(dx / k * 1e3)} mm), tol {tol}"


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
    """One panel per pilot group; its points are every (dx, k, tol) setting the pilot evaluated, at
    (worst level error over the budget bands, seconds per metre x 1000) read from pilot.parquet, each
    (dx, k) labelled "dx×k"; the starred point is the chosen (dx, k, tol)'s, named by its model grid
    in the title with the reference's (the data's grid refined K times); the budget is the dashed
    line; the reference is labelled."""
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
        assert any("finest (reference)" in t.get_text() for t in ax.texts)
        # every (dx, k) candidate drawn and labelled; the model grids of the refined ones among them
        labels = sorted(t.get_text().replace(" finest (reference)", "") for t in ax.texts)
        assert labels == sorted(plain(dx * 1e3) + (f"×{k}" if k > 1 else "") for dx, k in mine.select("dx", "refine").rows())
        assert mine["refine"].max() > 1
        reference = mine.filter(pl.col("reference"))
        assert reference.height == 1 and reference["refine"][0] == mine["refine"].max() and reference["tol"][0] == REFERENCE_TOL
        title = ax.get_title().replace("\n", " ")
        assert f"chosen: {setting_said(chosen['dx'][0], chosen['refine'][0], '10⁻⁸')}" in title, title
        assert f"reference: {setting_said(reference['dx'][0], reference['refine'][0], '10⁻⁶')}" in title, title
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
    # each group's own setting on its own readings, named
    assert "Every line run was solved on its own readings, as its pilot group chose" in text
    for name, group in plan["group_errors"].items():
        k = group["refine"]
        assert (f"{name}: dx = {plain(group['data_dx'] * 1e3)} mm, k = {k} (model grid "
                f"{plain(group['data_dx'] / k * 1e3)} mm), tol = 10⁻⁸") in text
    assert f"{plain(plan['speedup'])} times less solver work" in text
    assert f"the pilots took {plain(plan['pilot_seconds'])} s" in text
    assert f"Error budget {plain(plan['budget_db'])} dB" in text
    # On the model grid the synthetic 0.5 mm archive meets 0.2 dB (on the data's own grid it did not)
    assert plan["within_budget"] is True and min(g["refine"] for g in plan["group_errors"].values()) > 1
    assert "Within budget: yes" in text and "could not be met" not in text

    # What the sampling cannot tell, apart: the plan's spread per band, sampling-limited where above the budget
    spread = [plan["interpolant_spread_db"][str(b)] for b in bands]
    np.testing.assert_allclose([float(v) for v in column(table, "interpolant spread (dB): what the sampling cannot tell")],
                               spread, rtol=5e-3)
    assert column(table, "sampling-limited (spread above the budget)") == \
        ["yes" if v > plan["budget_db"] else "no" for v in spread]
    # ... and per group, the budget bands bands.parquet flags sampling_limited for its runs
    flagged = pl.read_parquet(results / "bands.parquet").filter(pl.col("reported") & pl.col("sampling_limited"))
    labels = dict(facts.select("band", "label").iter_rows())
    budget_bands = facts.filter(pl.col("in_budget"))["band"].to_list()
    for group, runs in plan["groups"].items():
        mine = sorted(set(flagged.filter(pl.col("run_id").is_in(runs) & pl.col("band").is_in(budget_bands))["band"]))
        said = f"{', '.join(labels[b] for b in mine)} mm ({len(mine)} of {len(budget_bands)})" if mine else "none"
        assert f"{group}: {said}" in text, (group, said)
    assert "Sampling-limited budget bands: " in text


def test_a_budget_missed_is_said_with_the_floor_of_the_settings_allowed(tmp_path: Path) -> None:
    """The synthetic archive forced onto the data's own grid (refine 1) misses 0.2 dB: the report
    says so, with the floor of the settings the pilots could choose (k = 1 and the tol given), not
    that of the reference, which the pilot solves on a finer grid for comparison only."""
    from roadtex.errors import ErrorBudgetWarning

    manifest = write_synthetic_archive(tmp_path / "archive", runs_per_kind=1, run_length=1.0)
    options = ProcessingOptions(youngs_moduli=(1e6,), segment_length=0.25, tol=1e-8, refine=1)
    with pytest.warns(ErrorBudgetWarning):
        process(manifest, tmp_path / "results", options, quiet=True)
    plan = json.loads((tmp_path / "results" / "parameters.json").read_text())["plan"]
    assert plan["within_budget"] is False and {g["refine"] for g in plan["group_errors"].values()} == {1}
    settings = worst_in_budget(pl.read_parquet(tmp_path / "results" / "pilot.parquet"))
    allowed = settings.filter((pl.col("refine") == 1) & (pl.col("tol") == 1e-8))
    floor = allowed.group_by("group").agg(pl.col("worst").min())["worst"].max()
    references = settings.filter(pl.col("reference"))
    assert floor > plan["budget_db"] and references["refine"].min() > 1 and references["worst"].max() < floor
    text = text_without_images(build_report(tmp_path / "results").html)
    assert "Within budget: no" in text and "could not be met by any setting the pilots could choose" in text
    assert f"the floor, is {plain(floor)} dB" in text
    assert "dx = 0.5 mm, k = 1 (model grid 0.5 mm), tol = 10⁻⁸" in text


def test_budget_off_and_missing_pilot_are_said(budget_off: dict, without_pilot: dict, results: Path) -> None:
    """Budget off: no estimate to tabulate, and the section says so with the setting used. No
    pilot.parquet: the plan's bands are still listed (labels from bands.parquet), and the section
    says no pilot was recorded."""
    off = parse(budget_off["report"].html)
    assert "band-errors" not in off.tables
    assert "the job ran with the error budget off (each run on its own readings: runs.parquet dx_used, refine, " \
        "tol_used)" in text_without_images(budget_off["report"].html)
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



def test_sampling_limited_bands_are_hatched_in_the_contact_spectra(drawn, results: Path) -> None:
    """In the enveloped-texture and pressure spectra, each pavement's panels hatch exactly the bands
    that bands.parquet flags sampling_limited for any of its runs (reported rows), under their tick
    labels, with one legend entry; a pavement with a band not flagged leaves that band clear."""
    pavements = pl.read_parquet(results / "segments.parquet").select("run_id", "pavement").unique()
    bands = (pl.read_parquet(results / "bands.parquet").filter(pl.col("reported") & (pl.col("model") == "line"))
             .join(pavements, on="run_id"))
    flagged = {p: set(b) for p, b in bands.filter(pl.col("sampling_limited")).group_by("pavement")
               .agg(pl.col("label").unique()).iter_rows()}
    assert flagged and any(len(labels) < bands["band"].n_unique() for labels in flagged.values()), \
        "every band flagged in every pavement: the hatching would not be told apart from a blanket"
    for name in ("texture_spectra", "pressure_spectra"):
        fig = drawn[name]
        panels = [ax for ax in fig.axes if ax.get_visible()]
        titled = {ax.get_title(): ax for ax in panels if ax.get_title()}
        assert set(titled) == set(bands["pavement"].unique()), name
        for ax in panels:
            pavement = next(t for t, a in titled.items() if a.get_position().x0 == ax.get_position().x0)
            column = [a for a in panels if a.get_position().x0 == ax.get_position().x0]
            labelled = column[-1]   # the bottom panel of the column carries the band labels
            positions = np.asarray(labelled.get_xticks())
            names = [t.get_text() for t in labelled.get_xticklabels()]
            hatched = {names[int(np.argmin(np.abs(positions - (p.get_x() + p.get_width() / 2))))] for p in ax.patches
                       if p.get_gid() == "sampling_limited"}
            assert all(p.get_hatch() for p in ax.patches if p.get_gid() == "sampling_limited")
            assert hatched == flagged.get(pavement, set()), (name, pavement)
        entries = [t.get_text() for legend in fig.legends for t in legend.get_texts()]
        assert sum("sampling-limited" in t for t in entries) == 1, entries




def test_spectra_rows_carry_one_axis_title(drawn) -> None:
    # side by side, each panel's band-axis title ran into its neighbour's: the row has one, the first
    for name in ("texture_spectra", "pressure_spectra"):
        titled = [ax for ax in drawn[name].axes if ax.get_visible() and ax.get_xlabel()]
        assert len(titled) == 1 and "centre wavelength (mm)" in titled[0].get_xlabel(), name


def test_a_quiet_rows_larger_statement_marks_a_band_only_when_it_moves_the_drawn_mean() -> None:
    """The report marks a band over the budget when the mean it draws may be off by more (each row's
    stated error weighted by its power), not whenever one row states more: a quiet row (a band with
    little power in its segment) states a larger error (bands.parquet level_error_db) but weighs
    little in the mean."""
    from types import SimpleNamespace

    from roadtex.report.data import over_budget_bands

    def table(quiet_level: float, quiet_error: float) -> pl.DataFrame:
        # band 20: three rows at 60 dB stating 0.1 dB and one quieter row stating more; band 21: 0.3 dB
        return pl.DataFrame({
            "run_id": ["a"] * 5, "band": [20, 20, 20, 20, 21], "youngs_modulus": [2e6] * 5, "model": ["line"] * 5,
            "enveloped_level": [60.0, 60.0, 60.0, quiet_level, 60.0],
            "pressure_level": [120.0, 120.0, 120.0, quiet_level + 60.0, 120.0],
            "level_error_db": [0.1, 0.1, 0.1, quiet_error, 0.3]})

    results = SimpleNamespace(options={"error_budget_db": 0.2},
                              run_groups=lambda: pl.DataFrame({"run_id": ["a"], "group": ["dense"]}))

    def mean_error(rows: pl.DataFrame) -> float:
        """The drawn mean raised by each row's own error, less the mean (dB), worked out here."""
        power = 10 ** (rows["enveloped_level"].to_numpy() / 10)
        raised = power * 10 ** (rows["level_error_db"].to_numpy() / 10)
        return float(10 * np.log10(raised.sum() / power.sum()))

    quiet = table(40.0, 1.0)       # 20 dB below: 1 dB stated, 1 % of the band's power
    assert mean_error(quiet.filter(pl.col("band") == 20)) < 0.2
    assert over_budget_bands(results, quiet) == {"dense": {21}}
    loud = table(60.0, 1.0)        # the same statement on a row as loud as the others: the mean moves
    assert mean_error(loud.filter(pl.col("band") == 20)) > 0.2
    assert over_budget_bands(results, loud) == {"dense": {20, 21}}


def test_a_reference_on_a_grid_of_its_own_is_no_floor_the_report_offers() -> None:
    """Segments of 499 readings (a prime): the pilot's reference is the same road on 500 k points, the
    grid of a 1 mm candidate; its rows (its own error only, far below any setting's) share that
    candidate's (dx, k, tol) and are no setting: the floor the report states is the best choosable one."""
    from types import SimpleNamespace

    import roadtex
    from roadtex.report.error_budget import floor_db, setting_points

    profile = roadtex.synthetic_pavement("dense_asphalt", 5.0, 0.5 / 499, seed=5)
    choice = roadtex.choose_setting(profile, youngs_moduli=(2e6,), mean_pressure=2e5, segment_length=0.5,
                                    interpolants=False, budget_db=1e-4, dx_candidates=[0.5 / 499, 1e-3],
                                    refine_candidates=[1, 2])
    study = choice.study.with_columns(pl.lit("g").alias("group"), pl.lit(False).alias("chosen"))
    reference = study.filter(pl.col("reference"))
    assert not reference["choosable"].any() and (reference["points"] == 500).all()
    floor, group = floor_db(SimpleNamespace(pilot=study, parameters={}))   # type: ignore[arg-type]
    assert group == "g" and floor == pytest.approx(choice.worst_error_db)
    assert floor > reference.filter(pl.col("in_budget"))["level_error_db"].max()
    points = setting_points(study)
    assert points.filter(pl.col("reference")).height == 1 and not points.filter(pl.col("reference"))["choosable"][0]
