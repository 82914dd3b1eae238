"""The report's spectral figures (reproducing the seed's figures 4.4 to 4.6) and the solver speed
against error. Every level axis states its reference (dB re 1 µm for texture, dB re 1 Pa for
pressure); every legend sits outside the axes."""

from __future__ import annotations

from typing import Any

import numpy as np
import polars as pl

import roadtex.plot as plot
from roadtex.report.data import (
    COLOURS,
    PRESSURE_DB,
    TEXTURE_DB,
    Results,
    legend_outside,
    mark_over_budget,
    modulus_label,
    over_budget_bands,
    power_mean_db,
)
from roadtex.spectra.analysis import band_regressions
from roadtex.spectra.bands import OCTAVE_BANDS, nominal_label


def band_axis(ax, labels: list[str], kind: str) -> None:
    ax.set_xticks(range(len(labels)))
    ax.set_xticklabels(labels, rotation=90)
    ax.set_xlabel(f"{'octave' if kind == 'octave' else 'one-third-octave'} band, centre wavelength (mm)")


#: The legend's name of a hatched band: what the data's sampling cannot tell exceeds the budget there.
LIMITED_LABEL = "sampling-limited band (interpolant spread above the error budget)"


def sampling_limited(results: Results) -> dict[str, set[int]]:
    """Per group (:meth:`~roadtex.report.data.Results.run_groups`), the bands that bands.parquet
    flags ``sampling_limited`` for any of its runs (none when the column is absent or null)."""
    if "sampling_limited" not in results.bands.columns:
        return {}
    flagged = (results.bands.filter(pl.col("sampling_limited").fill_null(False))
               .join(results.run_groups(), on="run_id", how="left")
               .group_by("group").agg(pl.col("band").unique()))
    return {str(group): set(bands) for group, bands in flagged.iter_rows()}


def hatch_limited(ax, bands: set[int], position: dict[int, int]) -> None:
    """A hatched span behind each sampling-limited band (gid "sampling_limited"): its contact
    levels are bounded by the data's resolution, not by the solver."""
    for band in sorted(b for b in bands if b in position):
        ax.axvspan(position[band] - 0.5, position[band] + 0.5, facecolor="none", edgecolor="0.75", hatch="\\\\\\",
                   lw=0.0, zorder=0, label=LIMITED_LABEL, gid="sampling_limited")


def budget_marks(results: Results) -> tuple[dict[str, set[int]], dict[str, set[int]]]:
    """Per group, the bands over the budget in its profile runs, and those over it in its surface
    runs only: a pavement's 1 mm surfaces state larger errors than its profiles, and marking the
    whole pavement red for them made bands look unreliable whose profile levels are within budget."""
    profiles = over_budget_bands(results, runs="profiles")
    surfaces = {group: bands - profiles.get(group, set())
                for group, bands in over_budget_bands(results, runs="surfaces").items()}
    return profiles, {group: bands for group, bands in surfaces.items() if bands}


def mean_spectra(results: Results, level: str) -> pl.DataFrame:
    group = "group"
    bands = results.bands.join(results.run_groups(), on="run_id", how="left")
    return (bands.filter(pl.col(level).is_finite())
            .group_by(group, "youngs_modulus", "band", maintain_order=True)
            .agg(pl.col("label").first(), power_mean_db(pl.col(level)).alias(level))
            .sort(group, "youngs_modulus", "band"))


def fig_texture_spectra(plt, results: Results):
    """Per pavement (column): original and enveloped texture levels per band and E, with the levels'
    stated numerical errors as error bars, and enveloped minus original below; drawn by
    :func:`roadtex.plot.band_levels`, as for a user."""
    bands = results.bands.join(results.run_groups(), on="run_id", how="left")
    groups = bands["group"].unique(maintain_order=True).to_list()
    limited = sampling_limited(results)
    over, surface_only = budget_marks(results)
    fig, axes = plt.subplots(2, len(groups), figsize=(3.4 * len(groups) + 2.0, 6.2), squeeze=False, sharex=True,
                             layout="constrained")
    kind = results.options.get("band_kind", "third_octave")
    for column, name in enumerate(groups):
        top, bottom = axes[0, column], axes[1, column]
        plot.band_levels(bands.filter(pl.col("group") == name), kind=kind, ax=(top, bottom))
        top.set_title(str(name))
        if column:   # one axis title for the row: side by side, each panel's ran into the next one's
            bottom.set_xlabel("")
        position = {b: b for b in bands["band"].unique().to_list()}   # roadtex.plot draws at the band number
        for ax in (top, bottom):   # the enveloped levels are the contact model's
            mark_over_budget(ax, sorted(over.get(str(name), ())))
            mark_over_budget(ax, sorted(surface_only.get(str(name), ())), surfaces=True)
            hatch_limited(ax, limited.get(str(name), set()), position)
    # every run's bands on the shared axis (runs of different samplings report different bands: each
    # panel's own ticks would leave the finer runs' shortest bands without a label)
    every = bands.select("band", "label").unique("band").sort("band")
    for bottom in axes[1]:
        bottom.set_xticks(every["band"].to_list())
        bottom.set_xticklabels(every["label"].to_list(), rotation=90)
    legend_outside(fig, [axes[0, 0], *fig.axes])   # the moduli's lines as in the first panel, the hatch from any
    return fig


def fig_pressure_spectra(plt, results: Results):
    group = "group"
    spectra = mean_spectra(results, "pressure_level")
    labels = results.bands.sort("band").select("band", "label").unique(maintain_order=True)
    position = {b: i for i, b in enumerate(labels["band"])}
    groups = spectra[group].unique(maintain_order=True).to_list()
    limited = sampling_limited(results)
    over, surface_only = budget_marks(results)
    fig, axes = plt.subplots(1, len(groups), figsize=(3.4 * len(groups) + 2.0, 3.6), squeeze=False, sharey=True,
                             layout="constrained")
    for ax, name in zip(axes[0], groups):
        mark_over_budget(ax, [position[b] for b in over.get(str(name), ()) if b in position])
        mark_over_budget(ax, [position[b] for b in surface_only.get(str(name), ()) if b in position], surfaces=True)
        for colour, e in zip(COLOURS, results.moduli):
            rows = spectra.filter((pl.col(group) == name) & (pl.col("youngs_modulus") == e))
            ax.plot([position[b] for b in rows["band"]], rows["pressure_level"], color=colour, lw=1.0,
                    marker=".", label=modulus_label(e))
        hatch_limited(ax, limited.get(str(name), set()), position)
        ax.set_title(str(name))
        band_axis(ax, labels["label"].to_list(), results.options.get("band_kind", "third_octave"))
        if ax is not axes[0, 0]:   # one axis title for the row (side by side they ran into each other)
            ax.set_xlabel("")
    axes[0, 0].set_ylabel(f"pressure level L_p ({PRESSURE_DB})")
    legend_outside(fig, [axes[0, 0], *fig.axes])   # the moduli's lines as in the first panel, the hatch from any
    return fig


LEVELS = ("enveloped_level", "pressure_level", "texture_level")


def octave_table(results: Results) -> pl.DataFrame:
    """Per run and E, the octave-band levels (third octaves n-1, n, n+1 of one row summed in power into
    octave n) of the enveloped profile and the pressure, energetically averaged over the run's rows
    (segments; a surface run's tiles, analysed lines and both models, as with octave bands).

    Only reported bands enter (:func:`~roadtex.report.data.read_reported_bands`); an octave is kept
    where all three of its third octaves have a level. Levels in dB re 1 µm (texture) and dB re 1 Pa
    (pressure). roadtex.spectra computes octave levels from the signals themselves
    (:func:`~roadtex.spectra.octave_levels`), not from third-octave levels, so the report sums them
    here: the job keeps only band levels."""
    kind = results.options.get("band_kind", "third_octave")
    bands = results.bands
    if kind == "third_octave":
        octave_of = {b + d: b for b in OCTAVE_BANDS for d in (-1, 0, 1)}
        bands = bands.with_columns(pl.col("band").replace_strict(octave_of, default=None).alias("octave"))
        # An octave needs all three of its third octaves reported, each with a level (a null level
        # would otherwise drop out of the power sum silently), of one row: a surface run's segment
        # holds a row per model and analysed line, each its own three bands
        rows = [c for c in ("model", "line") if c in bands.columns]
        complete = bands.filter(pl.col("octave").is_not_null()).group_by(
            "run_id", *rows, "segment", "youngs_modulus", "octave").agg(
            pl.len().alias("parts"),
            *[pl.when(pl.col(c).is_not_nan().sum() == 3).then(10.0 * (10.0 ** (pl.col(c) / 10.0)).sum().log10())
              .otherwise(None).alias(c) for c in LEVELS])
        bands = complete.filter(pl.col("parts") == 3).drop("parts").rename({"octave": "band"})
    per_run = (bands.group_by("run_id", "youngs_modulus", "band")
               .agg(*[power_mean_db(pl.col(c)).alias(c) for c in LEVELS])
               .with_columns(pl.col("band").map_elements(nominal_label, return_dtype=pl.String).alias("label"))
               .sort("band", "youngs_modulus", "run_id"))
    return per_run


def fig_pressure_vs_texture(plt, results: Results):
    octaves = octave_table(results).filter(pl.col("enveloped_level").is_finite() & pl.col("pressure_level").is_finite())
    fits = band_regressions(octaves, x="enveloped_level", y="pressure_level", by=("band", "youngs_modulus"))
    band_list = octaves["band"].unique().sort().to_list()
    if not band_list:  # no octave band with all three third octaves (e.g. surfaces too short)
        return None, fits
    columns = min(4, len(band_list))
    rows = int(np.ceil(len(band_list) / columns))
    fig, axes = plt.subplots(rows, columns, figsize=(3.0 * columns + 1.8, 2.7 * rows + 0.4), squeeze=False,
                             layout="constrained")
    for ax in axes.ravel()[len(band_list):]:
        ax.set_visible(False)
    # an octave holds the third octaves n-1, n, n+1: marked when one of them exceeds the budget in any run
    profiles, surface_only = budget_marks(results)
    over, over_surfaces = set().union(*profiles.values()), set().union(*surface_only.values())
    kind = results.options.get("band_kind", "third_octave")
    for ax, band in zip(axes.ravel(), band_list):
        parts = {band - 1, band, band + 1} if kind == "third_octave" else {band}
        if over & parts:
            ax.patch.set_facecolor("#fde8e8")
            ax.text(0.02, 0.98, "stated error exceeds the budget", transform=ax.transAxes, va="top", fontsize=7,
                    color="#d62728", gid="over_budget")
        elif over_surfaces & parts:
            ax.text(0.02, 0.98, "over the budget in surface runs only", transform=ax.transAxes, va="top",
                    fontsize=7, color="#ff7f0e", gid="over_budget_surfaces")
        for colour, e in zip(COLOURS, results.moduli):
            pts = octaves.filter((pl.col("band") == band) & (pl.col("youngs_modulus") == e))
            ax.scatter(pts["enveloped_level"], pts["pressure_level"], s=12, color=colour, label=modulus_label(e))
            fit = fits.filter((pl.col("band") == band) & (pl.col("youngs_modulus") == e))
            if fit.height and np.isfinite(fit["slope"][0]) and pts.height:
                xs = np.array([pts["enveloped_level"].min(), pts["enveloped_level"].max()])
                ax.plot(xs, fit["slope"][0] * xs + fit["intercept"][0], color=colour, lw=1.0)
        ax.set_title(f"octave {pts['label'][0] if pts.height else band} mm")
        ax.set_xlabel(f"enveloped texture level ({TEXTURE_DB})")
        ax.set_ylabel(f"pressure level ({PRESSURE_DB})")
    legend_outside(fig, axes[0, 0])
    return fig, fits


def fig_speed_vs_error(plt, benchmark: dict[str, Any]):
    fig, ax = plot.speed_vs_error(benchmark.get("rows", []))
    if fig is not None:
        ax.set_title("Speed against error (benchmark)")
    return fig
