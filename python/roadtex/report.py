"""The report: the seed's figures drawn for a processed archive, in one self-contained HTML file.

:func:`build_report` reads the tables that :func:`roadtex.archive.process` wrote (``segments``,
``bands``, ``runs`` and ``parameters.json``), re-reads one representative segment per pavement
type for the profile-level figures, and writes ``report.html`` (figures embedded as PNG data, no
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

import numpy as np
import polars as pl

#: Figure order and captions in the report.
FIGURES: dict[str, str] = {
    "fig_2_1_von_meier": "Figure 2.1: von Meier et al. envelopes at several curvature limits d* on one profile.",
    "fig_3_1_edge_effect": "Figure 3.1: the edge effect: pressure on a flat profile, finite sample against the periodic model.",
    "fig_4_1_envelopes": "Figure 4.1: enveloped profiles of each pavement at several rubber moduli E (INRETS periodic model).",
    "fig_4_2_pressures": "Figure 4.2: contact pressure distributions of the profiles of figure 4.1.",
    "fig_4_3_valley_penetration": "Figure 4.3: depth of penetration into each valley, below the line joining its two asperities, von Meier (d* = 0.054 1/mm) against INRETS at several E; negative where the rubber stays above that line.",
    "fig_4_4_texture_spectra": "Figure 4.4: texture spectra (band levels) of enveloped profiles (top) and their difference from the original profile (bottom).",
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


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"figure.dpi": 110, "axes.grid": True, "grid.alpha": 0.3, "font.size": 9,
                         "axes.titlesize": 10, "legend.fontsize": 8, "svg.fonttype": "none"})
    return plt


def _modulus_label(e: float) -> str:
    return f"E = {e / 1e6:g} MPa"


def _energetic_mean(levels: pl.Expr) -> pl.Expr:
    """Mean of levels in power (dB): 10 lg(mean 10^(L/10))."""
    return 10.0 * (10.0 ** (levels / 10.0)).mean().log10()


# --------------------------------------------------------------------------------------------
# Data
# --------------------------------------------------------------------------------------------

@dataclass
class _Results:
    root: Path
    segments: pl.DataFrame
    bands: pl.DataFrame
    runs: pl.DataFrame
    errors: pl.DataFrame
    parameters: dict[str, Any]

    @property
    def options(self) -> dict[str, Any]:
        return self.parameters.get("options", {})

    @property
    def moduli(self) -> list[float]:
        return sorted(self.segments["youngs_modulus"].unique().to_list())

    def group_column(self) -> str:
        """Pavement type when the manifest gave it, else the run id."""
        if self.segments["pavement"].null_count() < self.segments.height:
            return "pavement"
        return "run_id"


def _load(results_dir: Path) -> _Results:
    missing = [name for name in ("segments.parquet", "bands.parquet", "runs.parquet", "parameters.json")
               if not (results_dir / name).exists()]
    if missing:
        raise FileNotFoundError(f"{results_dir} is not a roadtex results folder: missing {', '.join(missing)} "
                                "(run `roadtex process MANIFEST --out DIR` first)")
    segments = pl.read_parquet(results_dir / "segments.parquet")
    if segments.height == 0:
        raise ValueError(f"{results_dir}/segments.parquet has no rows: every run failed (see errors.parquet)")
    errors_path = results_dir / "errors.parquet"
    return _Results(results_dir, segments, pl.read_parquet(results_dir / "bands.parquet"),
                    pl.read_parquet(results_dir / "runs.parquet"),
                    pl.read_parquet(errors_path) if errors_path.exists() else pl.DataFrame(),
                    json.loads((results_dir / "parameters.json").read_text()))


@dataclass
class _Example:
    """One representative segment of a pavement, solved at every modulus of the job."""

    group: str
    run_id: str
    dx: float
    heights: np.ndarray
    envelopes: dict[float, np.ndarray]
    pressures: dict[float, np.ndarray]


def _examples(results: _Results, max_groups: int = 4) -> list[_Example]:
    """The middle segment of the first run of each pavement type (or run), re-read and re-solved."""
    from roadtex.archive import ProcessingOptions
    from roadtex.contact import contact_many
    from roadtex.profile import read_profile

    options = ProcessingOptions(**results.options)
    column = results.group_column()
    runs = results.segments.select("run_id", column).unique(maintain_order=True)
    chosen = runs.group_by(column, maintain_order=True).first().head(max_groups)
    files = {run_id: (path, file_format) for run_id, path, file_format
             in results.runs.select("run_id", "path", "format").iter_rows()}
    examples = []
    for run_id, group in chosen.select("run_id", column).iter_rows():
        path, file_format = files[run_id]
        profile = read_profile(path, format=file_format).conditioned(dx=options.dx, spike_alpha=options.spike_alpha)
        segments = profile.segments(options.segment_length, options.segment_overlap)
        heights = segments.heights[len(segments) // 2]
        batch = contact_many(heights[None, :], segments.dx, results.moduli, options.mean_pressure,
                             poisson=options.poisson, tol=options.tol, raise_on_nonconvergence=False)
        examples.append(_Example(str(group), run_id, segments.dx, heights,
                                 {e: batch.envelope[0, k] for k, e in enumerate(results.moduli)},
                                 {e: batch.pressure[0, k] for k, e in enumerate(results.moduli)}))
    return examples


# --------------------------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------------------------

def _window(example: _Example, length: float = 0.1) -> slice:
    """A window of ``length`` (m) in the middle of the segment, so texture is visible at a glance."""
    n = example.heights.size
    points = min(n, max(8, int(round(length / example.dx))))
    first = (n - points) // 2
    return slice(first, first + points)


def fig_von_meier(plt, examples: list[_Example]):
    from roadtex.comparisons import von_meier_envelopes

    example = examples[0]
    view = _window(example)
    table = von_meier_envelopes(example.heights, example.dx, d_stars=(13.5, 27.0, 54.0, 108.0)).filter(
        (pl.col("index") >= view.start) & (pl.col("index") < view.stop))
    fig, ax = plt.subplots(figsize=(8, 3.2))
    first = table.filter(pl.col("d_star") == table["d_star"][0])
    ax.plot(first["x"] * _MM, first["height"] * _MM, color="0.3", lw=0.8, label="road profile")
    for colour, ((d_star,), rows) in zip(_COLOURS, table.group_by("d_star", maintain_order=True)):
        ax.plot(rows["x"] * _MM, rows["envelope"] * _MM, color=colour, lw=1.1, label=f"d* = {d_star / 1e3:g} 1/mm")
    ax.set(xlabel="distance x (mm)", ylabel="height z (mm)", title=f"von Meier envelopes, {example.group}")
    ax.legend(ncols=5, loc="lower center")
    return fig


def fig_edge_effect(plt, mean_pressure: float, modulus: float):
    from roadtex.comparisons import edge_effect

    length = 0.1
    table = edge_effect(points=1024, length=length, youngs_modulus=modulus, mean_pressure=mean_pressure, tol=1e-10)
    styles = {"finite": (_COLOURS[1], "-"), "periodic": (_COLOURS[0], "-"), "flat punch (exact)": ("0.4", ":")}
    fig, ax = plt.subplots(figsize=(8, 3.2))
    for (model,), rows in table.group_by("model", maintain_order=True):
        colour, style = styles.get(model, ("0.5", "--"))
        ax.plot(rows["x"] * _MM, rows["pressure"] / 1e6, color=colour, ls=style, label=model)
    ax.set(xlabel="distance x (mm)", ylabel="pressure p (MPa)", ylim=(0, 4 * mean_pressure / 1e6),
           title=f"Flat profile, L = {length * _MM:g} mm, {_modulus_label(modulus)}, P = {mean_pressure / 1e6:g} MPa")
    ax.legend()
    return fig


def _per_group(plt, examples: list[_Example], draw: Callable[[Any, _Example], None], ylabel: str, title: str):
    fig, axes = plt.subplots(len(examples), 1, figsize=(8, 2.2 * len(examples) + 0.4), squeeze=False, sharex=True)
    for ax, example in zip(axes[:, 0], examples):
        draw(ax, example)
        ax.set_ylabel(ylabel)
        ax.set_title(f"{example.group} (run {example.run_id})", loc="left")
    axes[-1, 0].set_xlabel("distance x (mm)")
    axes[0, 0].legend(ncols=len(examples[0].envelopes) + 1, loc="lower center", fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def fig_envelopes(plt, examples: list[_Example]):
    def draw(ax, example: _Example) -> None:
        view = _window(example)
        x = np.arange(example.heights.size)[view] * example.dx * _MM
        ax.plot(x, example.heights[view] * _MM, color="0.3", lw=0.8, label="road profile")
        for colour, (e, envelope) in zip(_COLOURS, example.envelopes.items()):
            ax.plot(x, envelope[view] * _MM, color=colour, lw=1.0, label=_modulus_label(e))

    return _per_group(plt, examples, draw, "height (mm)", "Enveloped profiles (INRETS periodic model)")


def fig_pressures(plt, examples: list[_Example]):
    def draw(ax, example: _Example) -> None:
        view = _window(example)
        x = np.arange(example.heights.size)[view] * example.dx * _MM
        for colour, (e, pressure) in zip(_COLOURS, example.pressures.items()):
            ax.plot(x, pressure[view] / 1e6, color=colour, lw=0.9, label=_modulus_label(e))
        ax.set_yscale("symlog", linthresh=0.1)

    return _per_group(plt, examples, draw, "p (MPa)", "Contact pressure (INRETS periodic model)")


def fig_valley_penetration(plt, examples: list[_Example], moduli: list[float], mean_pressure: float):
    from roadtex.comparisons import SEED_D_STAR, valley_penetration

    fig, axes = plt.subplots(1, len(examples), figsize=(3.2 * len(examples) + 0.6, 3.6), squeeze=False)
    for ax, example in zip(axes[0], examples):
        table = valley_penetration(example.heights, example.dx, youngs_moduli=moduli, mean_pressure=mean_pressure,
                                   tol=1e-8, min_depth=2e-5)
        top = 0.0
        for colour, e in zip(_COLOURS, moduli):
            rows = table.filter(pl.col("youngs_modulus") == e)
            ax.scatter(rows["von_meier_penetration"] * _MM, rows["inrets_penetration"] * _MM, s=10, color=colour,
                       alpha=0.8, label=_modulus_label(e))
            if rows.height:
                top = max(top, float(rows["von_meier_penetration"].max()), float(rows["inrets_penetration"].max()))
        ax.plot([0, top * _MM], [0, top * _MM], color="0.5", lw=0.7, ls=":", label="equal penetration")
        ax.set(xlabel=f"von Meier (d* = {SEED_D_STAR / 1e3:g} 1/mm) penetration (mm)",
               ylabel="INRETS penetration (mm)", title=example.group)
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def _band_axis(ax, labels: list[str], kind: str) -> None:
    ax.set_xticks(range(len(labels)))
    ax.set_xticklabels(labels, rotation=90)
    ax.set_xlabel(f"{'octave' if kind == 'octave' else 'one-third-octave'} band, centre wavelength (mm)")


def _mean_spectra(results: _Results, level: str) -> pl.DataFrame:
    group = results.group_column()
    bands = results.bands.join(results.segments.select("run_id", group).unique(), on="run_id", how="left")
    return (bands.filter(pl.col(level).is_finite())
            .group_by(group, "youngs_modulus", "band", maintain_order=True)
            .agg(pl.col("label").first(), _energetic_mean(pl.col(level)).alias(level))
            .sort(group, "youngs_modulus", "band"))


def fig_texture_spectra(plt, results: _Results):
    group = results.group_column()
    enveloped = _mean_spectra(results, "enveloped_level")
    original = _mean_spectra(results, "texture_level").filter(pl.col("youngs_modulus") == results.moduli[0])
    labels = results.bands.sort("band").select("band", "label").unique(maintain_order=True)
    position = {b: i for i, b in enumerate(labels["band"])}
    groups = enveloped[group].unique(maintain_order=True).to_list()
    fig, axes = plt.subplots(2, len(groups), figsize=(3.4 * len(groups) + 0.6, 6.2), squeeze=False, sharex=True)
    for column, name in enumerate(groups):
        top, bottom = axes[0, column], axes[1, column]
        base = original.filter(pl.col(group) == name)
        top.plot([position[b] for b in base["band"]], base["texture_level"], color="0.2", lw=1.6, label="original")
        for colour, e in zip(_COLOURS, results.moduli):
            rows = enveloped.filter((pl.col(group) == name) & (pl.col("youngs_modulus") == e))
            xs = [position[b] for b in rows["band"]]
            top.plot(xs, rows["enveloped_level"], color=colour, lw=1.0, label=_modulus_label(e))
            joined = rows.join(base.select("band", "texture_level"), on="band")
            bottom.plot([position[b] for b in joined["band"]], joined["enveloped_level"] - joined["texture_level"],
                        color=colour, lw=1.0, marker=".", label=_modulus_label(e))
        top.set(title=str(name), ylabel="texture level L_tx (dB re 1 µm)")
        bottom.set(ylabel="enveloped − original (dB)")
        bottom.axhline(0, color="0.5", lw=0.7)
        _band_axis(bottom, labels["label"].to_list(), results.options.get("band_kind", "third_octave"))
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def fig_pressure_spectra(plt, results: _Results):
    from roadtex.spectra import REFERENCE_PRESSURE

    group = results.group_column()
    spectra = _mean_spectra(results, "pressure_level")
    labels = results.bands.sort("band").select("band", "label").unique(maintain_order=True)
    position = {b: i for i, b in enumerate(labels["band"])}
    groups = spectra[group].unique(maintain_order=True).to_list()
    fig, axes = plt.subplots(1, len(groups), figsize=(3.4 * len(groups) + 0.6, 3.6), squeeze=False, sharey=True)
    for ax, name in zip(axes[0], groups):
        for colour, e in zip(_COLOURS, results.moduli):
            rows = spectra.filter((pl.col(group) == name) & (pl.col("youngs_modulus") == e))
            ax.plot([position[b] for b in rows["band"]], rows["pressure_level"], color=colour, lw=1.0,
                    marker=".", label=_modulus_label(e))
        ax.set_title(str(name))
        _band_axis(ax, labels["label"].to_list(), results.options.get("band_kind", "third_octave"))
    axes[0, 0].set_ylabel(f"pressure level L_p (dB re {REFERENCE_PRESSURE:g} Pa)")
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def octave_table(results: _Results) -> pl.DataFrame:
    """Per run and E, the octave-band levels (third octaves n-1, n, n+1 summed in power into octave n)
    of the enveloped profile and the pressure, energetically averaged over the run's segments."""
    from roadtex.spectra import OCTAVE_BANDS, nominal_label

    kind = results.options.get("band_kind", "third_octave")
    bands = results.bands
    if kind == "third_octave":
        octave_of = {b + d: b for b in OCTAVE_BANDS for d in (-1, 0, 1)}
        bands = bands.with_columns(pl.col("band").replace_strict(octave_of, default=None).alias("octave"))
        complete = bands.group_by("run_id", "segment", "youngs_modulus", "octave").agg(
            pl.len().alias("parts"),
            *[(10.0 * (10.0 ** (pl.col(c) / 10.0)).sum().log10()).alias(c)
              for c in ("enveloped_level", "pressure_level", "texture_level")])
        bands = complete.filter((pl.col("parts") == 3) & pl.col("octave").is_not_null()).rename({"octave": "band"})
    per_run = (bands.group_by("run_id", "youngs_modulus", "band")
               .agg(*[_energetic_mean(pl.col(c)).alias(c) for c in ("enveloped_level", "pressure_level", "texture_level")])
               .with_columns(pl.col("band").map_elements(nominal_label, return_dtype=pl.String).alias("label"))
               .sort("band", "youngs_modulus", "run_id"))
    return per_run


def fig_pressure_vs_texture(plt, results: _Results):
    from roadtex.spectra import band_regressions

    octaves = octave_table(results).filter(pl.col("enveloped_level").is_finite() & pl.col("pressure_level").is_finite())
    fits = band_regressions(octaves, x="enveloped_level", y="pressure_level", by=("band", "youngs_modulus"))
    band_list = octaves["band"].unique().sort().to_list()
    columns = min(4, len(band_list))
    rows = int(np.ceil(len(band_list) / columns))
    fig, axes = plt.subplots(rows, columns, figsize=(3.0 * columns + 0.5, 2.7 * rows + 0.4), squeeze=False)
    for ax in axes.ravel()[len(band_list):]:
        ax.set_visible(False)
    for ax, band in zip(axes.ravel(), band_list):
        for colour, e in zip(_COLOURS, results.moduli):
            pts = octaves.filter((pl.col("band") == band) & (pl.col("youngs_modulus") == e))
            ax.scatter(pts["enveloped_level"], pts["pressure_level"], s=12, color=colour, label=_modulus_label(e))
            fit = fits.filter((pl.col("band") == band) & (pl.col("youngs_modulus") == e))
            if fit.height and np.isfinite(fit["slope"][0]) and pts.height:
                xs = np.array([pts["enveloped_level"].min(), pts["enveloped_level"].max()])
                ax.plot(xs, fit["slope"][0] * xs + fit["intercept"][0], color=colour, lw=1.0)
        ax.set_title(f"octave {pts['label'][0] if pts.height else band} mm")
        ax.set_xlabel("enveloped texture level (dB re 1 µm)")
        ax.set_ylabel("pressure level (dB)")
    axes[0, 0].legend(fontsize=6)
    fig.tight_layout()
    return fig, fits


def fig_speed_vs_error(plt, benchmark: dict[str, Any]):
    rows = [r for r in benchmark.get("rows", []) if r.get("time_s") and r.get("l1_error") is not None]
    if not rows:
        return None
    table = pl.DataFrame(rows, infer_schema_length=None)
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    markers = {"westergaard": "o", "self_affine": "s"}
    for colour, ((solver,), group) in zip(_COLOURS, table.group_by("solver", maintain_order=True)):
        for case, sub in group.group_by("case", maintain_order=True):
            ax.scatter(sub["l1_error"], sub["time_s"], color=colour, marker=markers.get(case[0], "^"), s=18,
                       label=f"{solver} ({case[0]})")
    ax.set(xscale="log", yscale="log", xlabel="relative L1 pressure error", ylabel="time per solve (s)",
           title="Speed against error (benchmark)")
    ax.legend(fontsize=6)
    return fig


# --------------------------------------------------------------------------------------------
# The document
# --------------------------------------------------------------------------------------------

def run_table(results: _Results) -> pl.DataFrame:
    """The report's main table: per run, MPD and per E the contact fraction and mean levels."""
    seg = results.segments
    per_e = (seg.group_by("run_id", "youngs_modulus", maintain_order=True)
             .agg(pl.col("contact_fraction").mean(), pl.col("mean_gap").mean(), pl.col("max_pressure").max()))
    rows = results.runs.select("run_id", "length", "mpd").join(
        seg.select("run_id", results.group_column()).unique(), on="run_id", how="left")
    wide = rows
    for e in results.moduli:
        part = per_e.filter(pl.col("youngs_modulus") == e).select(
            "run_id", (pl.col("contact_fraction") * 100).alias(f"contact % ({e / 1e6:g} MPa)"))
        wide = wide.join(part, on="run_id", how="left")
    levels = (results.bands.filter(pl.col("youngs_modulus") == results.moduli[0])
              .group_by("run_id").agg(_energetic_mean(pl.col("texture_level")).alias("mean band level (dB)")))
    wide = wide.join(levels, on="run_id", how="left")
    return wide.with_columns((pl.col("mpd") * _MM).alias("MPD (mm)"), pl.col("length").alias("length (m)")) \
        .drop("mpd", "length").select("run_id", pl.exclude("run_id"))


def _html_table(table: pl.DataFrame) -> str:
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in table.columns)
    body = []
    for row in table.iter_rows():
        cells = []
        for value in row:
            text = f"{value:.3g}" if isinstance(value, float) else ("" if value is None else str(value))
            cells.append(f"<td>{html.escape(text)}</td>")
        body.append(f"<tr>{''.join(cells)}</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


_STYLE = """body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;color:#222}
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
    results = _load(Path(results_dir))
    out = Path(out_dir) if out_dir is not None else results.root / "report"
    figures_dir = out / "figures"
    figures_dir.mkdir(parents=True, exist_ok=True)
    plt = _pyplot()
    options = results.options
    examples = _examples(results)
    pressure = options.get("mean_pressure", 2e5)
    builders: dict[str, Callable[[], Any]] = {
        "fig_2_1_von_meier": lambda: fig_von_meier(plt, examples),
        "fig_3_1_edge_effect": lambda: fig_edge_effect(plt, pressure, results.moduli[len(results.moduli) // 2]),
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
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
        f"<p>{results.runs.height} runs, {results.runs['length'].sum() / 1e3:.3f} km of profile, "
        f"{results.segments.height} segment solutions; "
        f"E = {', '.join(f'{e / 1e6:g}' for e in results.moduli)} MPa, P = {pressure / 1e6:g} MPa, "
        f"segments of {options.get('segment_length', 0.5):g} m. "
        f"{n_errors} run(s) failed{' (see errors.parquet)' if n_errors else ''}. "
        f"roadtex {html.escape(str(results.parameters.get('versions', {}).get('roadtex', '?')))}.</p>",
        "<h2>Runs</h2>", _html_table(summary),
        "<h2>Figures</h2>", *sections,
        "<h2>Regressions of pressure level on texture level, per octave band and E</h2>",
        _html_table(regressions.select("band", "label", "youngs_modulus", "slope", "intercept", "r2", "n")),
        "</body></html>",
    ]
    report_path = out / "report.html"
    report_path.write_text("\n".join(parts), encoding="utf-8")
    return Report(report_path, written)
