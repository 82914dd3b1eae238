"""The report: the seed's figures drawn for a processed archive, in one self-contained HTML file.

:func:`build_report` reads only the outputs that :func:`roadtex.archive.process` wrote
(``segments``, ``bands``, ``runs``, ``examples``, ``edge_effect`` and ``parameters.json``): it
never re-reads a raw file nor solves a contact problem, so its figures show exactly what the
tables hold. It writes ``report.html`` (figures embedded as PNG data, no
network needed) plus every figure as PNG and SVG in ``figures/``.

Figures (numbers after the INRETS report of Klein & Hamet, the seed):
2.1 von Meier envelopes at several d* on one profile; 3.1 the edge effect of a finite sample;
4.1 enveloped profiles per pavement at several E; 4.2 their pressure distributions; 4.3 valley
penetration, von Meier against INRETS; 4.4 texture spectra of enveloped profiles and their
difference from the original; 4.5 pressure spectra; 4.6 pressure level against texture level per
octave band with a regression line per E; and solver speed against error when benchmark data
(``benches/speed_vs_error.py --json``) is given or found.
"""

from __future__ import annotations

import base64
import html
import io
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import polars as pl

from roadtex.report.data import MM, Results, energetic_mean, load_examples, load_results, pyplot
from roadtex.report.profile_figures import fig_edge_effect, fig_envelopes, fig_pressures, fig_valley_penetration, fig_von_meier
from roadtex.report.spectra_figures import fig_pressure_spectra, fig_pressure_vs_texture, fig_speed_vs_error, fig_texture_spectra

#: Figure order and captions in the report.
FIGURES: dict[str, str] = {
    "fig_2_1_von_meier": "Figure 2.1: von Meier et al. envelopes at several curvature limits d* on one profile.",
    "fig_3_1_edge_effect": "Figure 3.1: the edge effect: pressure on a flat profile, finite sample against the periodic model.",
    "fig_4_1_envelopes": "Figure 4.1: enveloped profiles of each pavement at several rubber moduli E (INRETS periodic model).",
    "fig_4_2_pressures": "Figure 4.2: contact pressure distributions of the profiles of figure 4.1.",
    "fig_4_3_valley_penetration": ("Figure 4.3: depth of penetration into each valley, below the line joining its two asperities, "
                                   "von Meier (d* = 0.054 1/mm) against INRETS at several E; negative where the rubber "
                                   "stays above that line."),
    "fig_4_4_texture_spectra": ("Figure 4.4: texture spectra (band levels) of enveloped profiles (top) and their "
                                "difference from the original profile (bottom)."),
    "fig_4_5_pressure_spectra": "Figure 4.5: band spectra of the contact pressure.",
    "fig_4_6_pressure_vs_texture": "Figure 4.6: pressure level against enveloped texture level per octave band, one regression line per E.",
    "fig_speed_vs_error": "Solver speed against error (from the benchmark data).",
}

_MM = 1e3
_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#17becf", "#7f7f7f")


@dataclass(frozen=True)
class Report:
    """What :func:`build_report` wrote."""

    html: Path
    figures: dict[str, list[Path]]


def run_table(results: Results) -> pl.DataFrame:
    """The report's main table: per run, MPD and per E the contact fraction and mean levels."""
    seg = results.segments
    per_e = (seg.group_by("run_id", "youngs_modulus", maintain_order=True)
             .agg(pl.col("contact_fraction").mean(), pl.col("mean_gap").mean(), pl.col("max_pressure").max()))
    rows = results.runs.select("run_id", "length", "mpd")
    if results.group_column() != "run_id":
        rows = rows.join(results.run_groups().rename({"group": results.group_column()}), on="run_id", how="left")
    wide = rows
    for e in results.moduli:
        part = per_e.filter(pl.col("youngs_modulus") == e).select(
            "run_id", (pl.col("contact_fraction") * 100).alias(f"contact % ({e / 1e6:g} MPa)"))
        wide = wide.join(part, on="run_id", how="left")
    levels = (results.bands.filter(pl.col("youngs_modulus") == results.moduli[0])
              .group_by("run_id").agg(energetic_mean(pl.col("texture_level")).alias("mean band level (dB)")))
    wide = wide.join(levels, on="run_id", how="left")
    return wide.with_columns((pl.col("mpd") * MM).alias("MPD (mm)"), pl.col("length").alias("length (m)")) \
        .drop("mpd", "length").select("run_id", pl.exclude("run_id"))


def html_table(table: pl.DataFrame) -> str:
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in table.columns)
    body = []
    for row in table.iter_rows():
        cells = []
        for value in row:
            text = f"{value:.3g}" if isinstance(value, float) else ("" if value is None else str(value))
            cells.append(f"<td>{html.escape(text)}</td>")
        body.append(f"<tr>{''.join(cells)}</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


STYLE = """body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;color:#222}
figure{margin:1.5em 0}figcaption{font-size:0.9em;color:#444}img{max-width:100%}
table{border-collapse:collapse;font-size:0.85em}th,td{border:1px solid #ccc;padding:2px 6px;text-align:right}
th{background:#f0f0f0}code{background:#f4f4f4}"""


def build_report(results_dir: str | os.PathLike[str], *, out_dir: str | os.PathLike[str] | None = None,
                 benchmark: str | os.PathLike[str] | None = None, title: str = "roadtex report") -> Report:
    """Draws the seed's figures for a processed archive into one self-contained HTML report.

    Args:
        results_dir: the folder written by :func:`roadtex.archive.process`.
        out_dir: where to write ``report.html`` and ``figures/`` (default ``results_dir/report``).
        benchmark: JSON rows of ``benches/speed_vs_error.py --json`` for the speed-against-error
            figure; by default ``results_dir/benchmark.json`` when present.
        title: the report's heading.

    Returns:
        A :class:`Report` with the HTML path and each figure's PNG and SVG paths.
    """
    results = load_results(Path(results_dir))
    out = Path(out_dir) if out_dir is not None else results.root / "report"
    figures_dir = out / "figures"
    figures_dir.mkdir(parents=True, exist_ok=True)
    plt = pyplot()
    options = results.options
    examples = load_examples(results)
    pressure = options.get("mean_pressure", 2e5)
    builders: dict[str, Callable[[], Any]] = {
        "fig_2_1_von_meier": lambda: fig_von_meier(plt, examples),
        "fig_3_1_edge_effect": lambda: fig_edge_effect(plt, results.edge_effect),
        "fig_4_1_envelopes": lambda: fig_envelopes(plt, examples),
        "fig_4_2_pressures": lambda: fig_pressures(plt, examples),
        "fig_4_3_valley_penetration": lambda: fig_valley_penetration(plt, examples, results.moduli, pressure),
        "fig_4_4_texture_spectra": lambda: fig_texture_spectra(plt, results),
        "fig_4_5_pressure_spectra": lambda: fig_pressure_spectra(plt, results),
    }
    regressions = None
    benchmark_path = Path(benchmark) if benchmark is not None else results.root / "benchmark.json"
    written: dict[str, list[Path]] = {}
    sections: list[str] = []

    def save(name: str, fig) -> None:
        buffer = io.BytesIO()
        fig.savefig(buffer, format="png", bbox_inches="tight")
        png = figures_dir / f"{name}.png"
        png.write_bytes(buffer.getvalue())
        svg = figures_dir / f"{name}.svg"
        fig.savefig(svg, format="svg", bbox_inches="tight")
        plt.close(fig)
        written[name] = [png, svg]
        data = base64.b64encode(buffer.getvalue()).decode("ascii")
        sections.append(f'<figure id="{name}"><img alt="{html.escape(FIGURES[name])}" '
                        f'src="data:image/png;base64,{data}"/><figcaption>{html.escape(FIGURES[name])}'
                        f"</figcaption></figure>")

    for name, build in builders.items():
        save(name, build())
    fig, regressions = fig_pressure_vs_texture(plt, results)
    save("fig_4_6_pressure_vs_texture", fig)
    if benchmark_path.exists():
        fig = fig_speed_vs_error(plt, json.loads(benchmark_path.read_text()))
        if fig is not None:
            save("fig_speed_vs_error", fig)

    summary = run_table(results)
    n_errors = results.errors.height
    parts = [
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8"/>',
        f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
        f"<p>{results.runs.height} runs, {results.runs['length'].sum() / 1e3:.3f} km of profile, "
        f"{results.segments.height} segment solutions; "
        f"E = {', '.join(f'{e / 1e6:g}' for e in results.moduli)} MPa, P = {pressure / 1e6:g} MPa, "
        f"segments of {options.get('segment_length', 0.5):g} m. "
        f"{n_errors} run(s) failed{' (see errors.parquet)' if n_errors else ''}. "
        f"roadtex {html.escape(str(results.parameters.get('versions', {}).get('roadtex', '?')))}.</p>",
        "<h2>Runs</h2>", html_table(summary),
        "<h2>Figures</h2>", *sections,
        "<h2>Regressions of pressure level on texture level, per octave band and E</h2>",
        html_table(regressions.select("band", "label", "youngs_modulus", "slope", "intercept", "r2", "n")),
        "</body></html>",
    ]
    report_path = out / "report.html"
    report_path.write_text("\n".join(parts), encoding="utf-8")
    return Report(report_path, written)
