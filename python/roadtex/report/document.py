"""The report: the seed's figures drawn for a processed archive, in one self-contained HTML file.

:func:`build_report` reads only the outputs that :func:`roadtex.archive.process` wrote
(``segments``, ``bands``, ``runs``, ``errors``, ``examples``, ``edge_effect``, ``von_meier``,
``penetration``, ``pilot`` and ``parameters.json``): it never re-reads a raw file nor solves a
contact problem nor computes an envelope (the von Meier envelopes and the valley penetrations of
figures 2.1 and 4.3 are the job's tables), so its figures show
exactly what the tables hold. It writes ``report.html`` (figures embedded as PNG data, no network
needed) plus every figure as PNG and SVG in ``figures/``.

The document holds: a summary; the failed runs (from ``errors.parquet``, or a line saying there
were none); per run the results (MPD, contact fraction per E, mean texture level) and the
conditioning facts (sampling intervals, model grid, solver tolerance, trimmed length, reference plates, share
of readings removed, warnings, MPD validity); the numerical error per band (the error budget, the
setting used (dx, k, tol), whether it was met, the speed-up, each band's estimated error and, apart
from it, what the data's sampling cannot tell and the bands it makes sampling-limited; see
:mod:`~roadtex.report.error_budget`); the figures; the regressions of figure "pressure against
texture". Figures are numbered by their order in the document (Figure 1, 2, ...); each caption says
which figure of the INRETS report (Klein & Hamet, the seed) it reproduces: 2.1 von Meier envelopes
at several d*; 3.1 the edge effect of a finite sample; 4.1 enveloped profiles per pavement at
several E; 4.2 their pressure distributions; 4.3 valley penetration, von Meier against INRETS; 4.4
texture spectra of enveloped profiles and their difference from the original; 4.5 pressure
spectra; 4.6 pressure level against texture level per octave band with a regression line per E;
then, always, the speed against error of every setting the error-budget pilot evaluated (saying so
when there was no pilot); then solver speed against error when benchmark data (``benches/speed_vs_error.py --json``) is given
or found; then, when the results hold surface runs (areal rows), one tile per pavement with its
enveloped surface and pressure map, the line against areal enveloped levels per band and E, and a
table of the bands where the line model is within 0.5 dB of the areal one
(:mod:`~roadtex.report.surface_figures`). Moduli and pressures are in MPa, levels in dB re 1 µm (texture) and dB re 1 Pa
(pressure).
"""

from __future__ import annotations

import base64
import html
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import polars as pl

from roadtex.errors import InvalidInputError
from roadtex.report.data import (
    MM,
    PRESSURE_DB,
    TEXTURE_DB,
    Results,
    load_examples,
    load_results,
    megapascals,
    plain,
    power_mean_db,
    pyplot,
    save_png_and_svg,
    tolerance,
)
from roadtex.report.error_budget import (
    band_error_table,
    budget_summary,
    fig_setting_speed_vs_error,
    pilot_state,
    sampling_summary,
)
from roadtex.report.profile_figures import fig_edge_effect, fig_envelopes, fig_pressures, fig_valley_penetration, fig_von_meier
from roadtex.report.sampling_section import sampling_section
from roadtex.report.section_figures import sections_part
from roadtex.report.spectra_figures import fig_pressure_spectra, fig_pressure_vs_texture, fig_speed_vs_error, fig_texture_spectra
from roadtex.report.surface_figures import (
    AGREEMENT_DB,
    SURFACE_FIGURES,
    agreement_table,
    fig_line_vs_areal,
    fig_surface_tiles,
    surface_error_table,
)

#: Figure order and captions in the report (without their number: a figure's number is its place in
#: the document); the 3D-surface figures, drawn only for surface runs, follow (:data:`SURFACE_FIGURES`).
#: ``{envelopes}`` stands for the number of the enveloped-profiles figure.
FIGURES: dict[str, str] = {
    "von_meier": "von Meier et al. envelopes at several curvature limits d* on one profile.",
    "edge_effect": "The edge effect: pressure on a flat profile, finite sample against the periodic model.",
    "envelopes": "Enveloped profiles of each pavement at several rubber moduli E (INRETS periodic model).",
    "pressures": "Contact pressure distributions of the profiles of Figure {envelopes}.",
    "valley_penetration": ("Depth of penetration into each valley, below the line joining its two asperities, "
                           "von Meier (d* = 0.054 1/mm) against INRETS at several E; negative where the rubber "
                           "stays above that line."),
    "texture_spectra": (f"Texture spectra (band levels, {TEXTURE_DB}) of enveloped profiles (top) and their "
                        "difference from the original profile (bottom). Hatched: sampling-limited bands, where "
                        "what the data's sampling cannot tell exceeds the error budget."),
    "pressure_spectra": (f"Band spectra of the contact pressure ({PRESSURE_DB}). Hatched: sampling-limited "
                         "bands, where what the data's sampling cannot tell exceeds the error budget."),
    "pressure_vs_texture": (f"Pressure level ({PRESSURE_DB}) against enveloped texture level ({TEXTURE_DB}) "
                            "per octave band, one regression line per E."),
    "setting_speed_vs_error": (
        "Speed against error of the processed archive: for each device/pavement group, every setting "
        "(sampling interval dx, model grid k times finer than the data's, solver tolerance tol) the error-budget "
        "pilot evaluated, each point labelled dx (mm)×k, its measured solve time per km of road (every modulus) "
        "against its worst estimated level error in the tyre/road noise bands; the group's chosen (dx, k, tol) "
        "starred, the reference (the data's grid refined K times, the converged answer, at its own estimated "
        "error) boxed, settings whose dx does not report every budget band as triangles at the right edge, the "
        "budget dashed. The pilot chooses "
        "by solver work (iterations × N log₂ N), which the machine's load does not move; the times shown are "
        "measured."),
    "speed_vs_error": "Solver speed against error (from the benchmark data).",
}
#: The figure of the INRETS report (the seed) that each figure reproduces.
SEED_FIGURES: dict[str, str] = {
    "von_meier": "2.1", "edge_effect": "3.1", "envelopes": "4.1", "pressures": "4.2", "valley_penetration": "4.3",
    "texture_spectra": "4.4", "pressure_spectra": "4.5", "pressure_vs_texture": "4.6",
}


@dataclass(frozen=True)
class Report:
    """What :func:`build_report` wrote: the HTML file and, per figure name, its PNG and SVG."""

    html: Path
    figures: dict[str, list[Path]]


def draw_figures(results: Results, benchmark: dict[str, Any] | None = None) -> tuple[dict[str, Any], pl.DataFrame]:
    """The report's matplotlib figures, in document order (names as in :data:`FIGURES`), and the
    regressions of pressure level on texture level drawn in ``pressure_vs_texture``.

    Args:
        results: the job's tables (:func:`~roadtex.report.data.load_results`).
        benchmark: the JSON object of ``benches/speed_vs_error.py --json``, or None (no such figure).

    The caller closes the figures (``matplotlib.pyplot.close``).
    """
    plt = pyplot()
    examples = load_examples(results)
    empty = pl.DataFrame()
    von_meier = results.von_meier if results.von_meier is not None else empty
    penetration = results.penetration if results.penetration is not None else empty
    # the profile figures draw the line runs' example segments: a job of surface runs only has none
    figures: dict[str, Any] = {
        "von_meier": fig_von_meier(plt, examples, von_meier) if examples else None,
        "edge_effect": fig_edge_effect(plt, results.edge_effect),
        "envelopes": fig_envelopes(plt, examples) if examples else None,
        "pressures": fig_pressures(plt, examples) if examples else None,
        "valley_penetration": (fig_valley_penetration(plt, examples, results.moduli, penetration)
                               if examples else None),
        "texture_spectra": fig_texture_spectra(plt, results),
        "pressure_spectra": fig_pressure_spectra(plt, results),
    }
    figures["pressure_vs_texture"], regressions = fig_pressure_vs_texture(plt, results)
    figures = {name: fig for name, fig in figures.items() if fig is not None}
    figures["setting_speed_vs_error"] = fig_setting_speed_vs_error(plt, results)
    if benchmark is not None:
        fig = fig_speed_vs_error(plt, benchmark)
        if fig is not None:
            figures["speed_vs_error"] = fig
    if results.surface_bands is not None:
        for name, draw in (("surface_tiles", fig_surface_tiles), ("line_vs_areal", fig_line_vs_areal)):
            fig = draw(plt, results)
            if fig is not None:
                figures[name] = fig
    return figures, regressions


def captions(names: list[str], notes: dict[str, str] | None = None) -> dict[str, str]:
    """Each figure's caption, numbered by its place in ``names`` (the document's order), with the
    seed figure it reproduces: "Figure 3: ... (reproduces figure 4.1 of the INRETS report).", and
    the sentence ``notes[name]`` after it when given."""
    numbers = {name: index + 1 for index, name in enumerate(names)}
    known = {**FIGURES, **SURFACE_FIGURES}
    fields = {name: numbers.get(name, "?") for name in known}
    out = {}
    for name in names:
        text = known[name].format(**fields)
        if name in SEED_FIGURES:
            text = f"{text[:-1]} (reproduces figure {SEED_FIGURES[name]} of the INRETS report)."
        if notes and notes.get(name):
            text = f"{text} {notes[name]}"
        out[name] = f"Figure {numbers[name]}: {text}"
    return out


def distance(metres: float) -> str:
    """A total length of profile: in km from 1 km, else in m."""
    return f"{plain(metres / 1e3, 4)} km" if metres >= 1e3 else f"{plain(metres, 4)} m"


def modulus_column(e: float) -> str:
    return f"E = {megapascals(e)}"


def run_table(results: Results) -> pl.DataFrame:
    """The report's main table: per run, length (m), MPD (mm; null where undefined) and whether it
    is valid (ISO 13473-1: half the baselines valid) with why baselines were rejected, and per E the
    contact fraction (%) and the mean texture level of the original profile (dB re 1 µm, energetic
    mean over the run's reported bands and segments)."""
    seg = results.segments
    per_e = (seg.group_by("run_id", "youngs_modulus", maintain_order=True)
             .agg(pl.col("contact_fraction").mean(), pl.col("mean_gap").mean(), pl.col("max_pressure").max()))
    # the MPD's ISO validity beside it: a run with few valid baselines still has a number
    wide = results.runs.select("run_id", pl.col("length").alias("length (m)"),
                               (pl.col("mpd").fill_nan(None) * MM).alias("MPD (mm)"),
                               pl.when(pl.col("mpd_valid")).then(pl.lit("yes")).otherwise(pl.lit("no"))
                               .alias("MPD valid"))
    if "mpd_rejections" in results.runs.columns:   # why baselines were rejected (absent from older jobs' tables)
        wide = wide.join(results.runs.select("run_id", pl.col("mpd_rejections").fill_null("none")
                                             .alias("MPD baselines rejected")), on="run_id", how="left")
    if results.group_column() != "run_id":
        groups = results.run_groups().rename({"group": results.group_column()})
        wide = groups.join(wide, on="run_id", how="right").select("run_id", pl.exclude("run_id"))
    for e in results.moduli:
        part = per_e.filter(pl.col("youngs_modulus") == e).select(
            "run_id", (pl.col("contact_fraction") * 100).alias(f"contact % ({modulus_column(e)})"))
        wide = wide.join(part, on="run_id", how="left")
    levels = (results.bands.filter(pl.col("youngs_modulus") == results.moduli[0])
              .group_by("run_id").agg(power_mean_db(pl.col("texture_level")).alias(f"mean texture band level ({TEXTURE_DB})")))
    return wide.join(levels, on="run_id", how="left")


#: runs.parquet's conditioning columns, their headings in the report and the factor to those units.
CONDITIONING: dict[str, tuple[str, float]] = {
    "file_dx": ("file dx (mm)", MM), "dx": ("dx (mm)", MM), "dx_used": ("dx (mm)", MM),
    "refine": ("k (model grid dx / k)", 1.0), "model_dx": ("model dx (mm)", MM), "tol_used": ("tol", 1.0),
    "raw_length": ("read (m)", 1.0),
    "trimmed_length": ("trimmed (mm)", MM), "plates": ("reference plates", 1.0),
    "dropout_fraction": ("drop-outs (%)", 100.0), "spike_fraction": ("spikes (%)", 100.0),
    "outlier_fraction": ("outliers (%)", 100.0), "mpd": ("MPD (mm)", MM), "mpd_valid": ("MPD valid", 1.0),
    "conditioning_warnings": ("warnings", 1.0),
}


def conditioning_table(results: Results) -> pl.DataFrame:
    """Per run, what conditioning did (runs.parquet): the file's and the job's sampling interval
    (mm), the model grid's refinement k and interval (mm), the solver tolerance, the length read
    (m) and trimmed (mm), the reference plates found, the share of readings that were drop-outs,
    spikes and outliers (%), the warnings, and MPD (mm, null where undefined) with its ISO 13473-1
    validity and valid/all baselines. Columns missing from an older job's table are left out."""
    runs = results.runs
    columns: list[pl.Expr] = [pl.col("run_id")]
    for name, (heading, factor) in CONDITIONING.items():
        if name not in runs.columns:
            continue
        column = pl.col(name)
        if runs.schema[name].is_float():
            column = column.fill_nan(None) * factor
        elif name == "conditioning_warnings":
            column = column.fill_null("none")
        if name == "tol_used":
            column = pl.col(name).map_elements(tolerance, return_dtype=pl.String)
        columns.append(column.alias(heading))
        if name == "mpd_valid" and {"mpd_valid_baselines", "mpd_baselines"} <= set(runs.columns):
            columns.append(pl.format("{}/{}", "mpd_valid_baselines", "mpd_baselines").alias("valid MPD baselines"))
    return runs.select(columns)


def error_table_section(results: Results) -> str:
    """The table "numerical error per band" (:func:`~roadtex.report.error_budget.band_error_table`),
    or nothing when the plan has no estimate (the summary says why)."""
    table = band_error_table(results)
    if table.height == 0:
        return ""
    return ("<p>Upper estimates of the numerical error of every level of each band (bands.parquet "
            "level_error_db is the job's column), and per pilot group at its own chosen setting:</p>"
            + html_table(table, classes="band-errors") + sampling_summary(results))


def failure_table(results: Results) -> pl.DataFrame:
    """errors.parquet as the report shows it: run id, stage, error type, message and file."""
    columns = {"run_id": "run_id", "stage": "stage", "error_type": "error type", "message": "message", "path": "file"}
    errors = results.errors
    return errors.select([pl.col(c).alias(h) for c, h in columns.items() if c in errors.columns])


def failure_section(results: Results) -> str:
    if not results.errors.columns:
        return "<p>No errors.parquet in the results folder: failed runs, if any, are not on record.</p>"
    if results.errors.height == 0:
        return "<p>No failed runs: every run of the manifest was processed (errors.parquet is empty).</p>"
    return (f"<p>{results.errors.height} run(s) failed and are not in the tables or figures below "
            "(errors.parquet; <code>roadtex process --retry-failed</code> tries them again):</p>"
            + html_table(failure_table(results), classes="failures"))


def surface_section(results: Results) -> list[str]:
    """The 3D surfaces' table (nothing when the results hold no areal row)."""
    if results.surface_bands is None:
        return []
    section = [f"<h2>3D surfaces: where the line model is within {AGREEMENT_DB:g} dB of the areal model</h2>",
               f"<p>Per pavement and E, the bands whose mean enveloped level on the surface's lines (line model) "
               f"differs by at most {AGREEMENT_DB:g} dB from the areal model's on the same lines.</p>",
               html_table(agreement_table(results), classes="surfaces")]
    errors = surface_error_table(results)
    if errors.height:
        section += ["<p>The numerical error of those levels: per pavement and band, the largest upper estimate "
                    "over its surface runs (bands.parquet level_error_db, from each run's own areal pilot: a few "
                    "tiles solved again to convergence and on finer grids). A line-minus-areal difference "
                    "smaller than the two models' errors together is not resolved by the data's sampling.</p>",
                    html_table(errors, classes="surface-errors")]
    else:
        section.append("<p>The surface runs' levels have no error estimate (error budget off, or tiles too large "
                       "for the areal pilot).</p>")
    return section


def cell(value: Any) -> str:
    """A table cell's text: numbers to 3 significant digits without exponent, "n/a" for a missing
    number, yes/no for booleans."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return plain(value)
    if value is None:
        return "n/a"
    return str(value)


def html_table(table: pl.DataFrame, classes: str = "") -> str:
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in table.columns)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(cell(v))}</td>" for v in row) + "</tr>"
                   for row in table.iter_rows())
    attribute = f' class="{classes}"' if classes else ""
    return f"<table{attribute}><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def regression_table(regressions: pl.DataFrame) -> pl.DataFrame:
    return regressions.select(
        pl.col("label").alias("octave band (mm)"), (pl.col("youngs_modulus") / 1e6).alias("E (MPa)"),
        pl.col("slope").alias("slope (dB/dB)"), pl.col("intercept").alias(f"intercept ({PRESSURE_DB})"),
        pl.col("r2").alias("r²"), pl.col("n"))


STYLE = """body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;color:#222}
figure{margin:1.5em 0}figcaption{font-size:0.9em;color:#444}img{max-width:100%}
table{border-collapse:collapse;font-size:0.85em}th,td{border:1px solid #ccc;padding:2px 6px;text-align:right}
th{background:#f0f0f0}code{background:#f4f4f4}.warning{color:#8a1c00}td:first-child,.failures td,.conditioning td:nth-child(9),
.conditioning td:last-child{text-align:left}"""


def read_benchmark(path: Path) -> dict[str, Any]:
    """The JSON object ``benches/speed_vs_error.py --json`` writes (``rows``: a list of objects), or
    an InvalidInputError naming the file (not JSON, not UTF-8, not such an object)."""
    try:
        stored = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InvalidInputError(f"benchmark {path.name}: not readable JSON ({type(exc).__name__}: "
                                f"{str(exc)[:120]})") from None
    if not isinstance(stored, dict) or not isinstance(stored.get("rows", []), list):
        raise InvalidInputError(f"benchmark {path.name}: expected an object with a list of rows (benches/speed_vs_error.py "
                                f"--json writes one), got {type(stored).__name__}")
    return stored


def build_report(results_dir: str | os.PathLike[str], *, out_dir: str | os.PathLike[str] | None = None,
                 benchmark: str | os.PathLike[str] | None = None, title: str = "roadtex report") -> Report:
    """Draws the seed's figures and the job's tables (failed runs included) into one self-contained HTML report.

    Args:
        results_dir: the folder written by :func:`roadtex.archive.process`.
        out_dir: where to write ``report.html`` and ``figures/`` (default ``results_dir/report``).
        benchmark: JSON rows of ``benches/speed_vs_error.py --json`` for the speed-against-error
            figure; by default ``results_dir/benchmark.json`` when present.
        title: the report's heading.

    Returns:
        A :class:`Report` with the HTML path and each figure's PNG and SVG paths.

    Raises:
        ResultsNotFoundError: ``results_dir`` is not a finished job's folder (the message names
            the missing tables).
    """
    results = load_results(Path(results_dir))
    out = Path(out_dir) if out_dir is not None else results.root / "report"
    figures_dir = out / "figures"
    figures_dir.mkdir(parents=True, exist_ok=True)
    options = results.options
    benchmark_path = Path(benchmark) if benchmark is not None else results.root / "benchmark.json"
    bench_rows = read_benchmark(benchmark_path) if benchmark_path.exists() else None
    plt = pyplot()
    figures, regressions = draw_figures(results, bench_rows)
    numbered = captions(list(figures), {"setting_speed_vs_error": pilot_state(results) or ""})
    written: dict[str, list[Path]] = {}
    sections: list[str] = []
    for number, (name, fig) in enumerate(figures.items(), start=1):
        png = figures_dir / f"figure_{number}_{name}.png"
        svg = png.with_suffix(".svg")
        png_bytes = save_png_and_svg(fig, svg)
        png.write_bytes(png_bytes)
        plt.close(fig)
        written[name] = [png, svg]
        data = base64.b64encode(png_bytes).decode("ascii")
        caption = html.escape(numbered[name])
        sections.append(f'<figure id="{name}"><img alt="{caption}" src="data:image/png;base64,{data}"/>'
                        f"<figcaption>{caption}</figcaption></figure>")

    pressure = options.get("mean_pressure", 2e5)
    n_errors = results.errors.height
    version = html.escape(str(results.parameters.get("versions", {}).get("roadtex", "?")))
    parts = [
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8"/>',
        f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
        f"<p>{results.runs.height} runs, {distance(float(results.runs['length'].sum()))} of profile, "
        f"{results.segments.height} segment solutions; "
        f"E = {', '.join(plain(e / 1e6, 4) for e in results.moduli)} MPa, P = {megapascals(pressure)}, "
        f"segments of {plain(options.get('segment_length', 0.5) * MM, 4)} mm. "
        f"{n_errors} run(s) failed{' (listed below)' if n_errors else ''}. "
        f"Texture levels in {TEXTURE_DB}, pressure levels in {PRESSURE_DB}. roadtex {version}.</p>",
        "<h2>Failed runs</h2>", failure_section(results),
        "<h2>Runs</h2>", html_table(run_table(results), classes="runs"),
        "<h2>Conditioning of each run</h2>",
        "<p>Sampling intervals (the file's, and the job's one dx for all runs), the model grid the contact model was "
        "solved on (k times finer than dx, every model dx) and solver tolerance, length read and trimmed away "
        "with the reference plates, share of readings that were drop-outs, spikes or outliers (replaced by "
        "interpolation), and MPD (ISO 13473-1) with its validity; n/a where MPD is undefined. A 100 mm baseline is "
        "valid when at most 10 % of its raw readings are drop-outs and at most 5 % spikes; MPD is valid when at "
        "least half the baselines are (ISO 13473-1), so a run with many drop-outs gets no valid MPD.</p>",
        html_table(conditioning_table(results), classes="conditioning"),
        "<h2>Numerical error per band</h2>", budget_summary(results), error_table_section(results),
        "<h2>What the sampling cannot tell</h2>", sampling_section(results, html_table),
        "<h2>Figures</h2>", *sections,
        "<h2>Regressions of pressure level on texture level, per octave band and E</h2>",
        html_table(regression_table(regressions), classes="regressions"),
        *surface_section(results),
        *sections_part(results.root, figures_dir),
        "</body></html>",
    ]
    report_path = out / "report.html"
    report_path.write_text("\n".join(parts), encoding="utf-8")
    return Report(report_path, written)
