"""The report's 3D-surface part (surface runs of the bulk job): one tile per pavement, its enveloped
surface and pressure map; line against areal enveloped levels per band and E (the seed's figure
4.4 in 3D); per pavement, the bands where the line model is within :data:`AGREEMENT_DB` of the
areal one. Drawn only when the results hold areal rows."""

from __future__ import annotations

import numpy as np
import polars as pl

import roadtex.plot as plot
from roadtex.report.data import COLOURS, Results, legend_outside, mark_over_budget, modulus_label, over_budget_bands

#: Captions of the 3D-surface figures (after the seed's figures; drawn only when the results hold areal rows).
SURFACE_FIGURES: dict[str, str] = {
    "surface_tiles": ("3D surfaces: one tile per pavement, its enveloped surface (mm, areal model) and its "
                      "contact pressure map (MPa), at the job's middle E."),
    "line_vs_areal": ("3D surfaces: line model minus areal model enveloped level (dB) per band and E, mean over "
                      "the tiles and lines of each pavement; the grey band is ±0.5 dB."),
}
#: The line model "agrees" with the areal one in a band when its mean enveloped level is within this (dB).
AGREEMENT_DB = 0.5


def surface_groups(results: Results) -> pl.DataFrame:
    """One row per surface run: ``run_id`` and ``group`` (pavement, else the run id)."""
    assert results.surface_bands is not None
    groups = results.run_groups()
    runs = results.surface_bands.select("run_id").unique(maintain_order=True)
    return runs.join(groups, on="run_id", how="left").with_columns(pl.col("group").fill_null(pl.col("run_id")))


def line_minus_areal(results: Results) -> pl.DataFrame:
    """Per pavement, E and band: mean over tiles and lines of (line − areal) enveloped level (dB)."""
    assert results.surface_bands is not None
    bands = results.surface_bands.filter(pl.col("enveloped_level").is_not_null())
    keys = ["run_id", "segment", "line", "youngs_modulus", "band"]
    line = bands.filter(pl.col("model") == "line").select(*keys, "label", pl.col("enveloped_level").alias("line_level"))
    areal = bands.filter(pl.col("model") == "areal").select(*keys, pl.col("enveloped_level").alias("areal_level"))
    joined = line.join(areal, on=keys).join(surface_groups(results), on="run_id", how="left")
    return (joined.group_by("group", "youngs_modulus", "band", maintain_order=True)
            .agg(pl.col("label").first(), (pl.col("line_level") - pl.col("areal_level")).mean().alias("difference_db"))
            .sort("group", "youngs_modulus", "band"))


def agreement_table(results: Results) -> pl.DataFrame:
    """Per pavement and E: the bands where |line − areal| mean enveloped level <= :data:`AGREEMENT_DB`,
    and those where it is not (band labels, centre wavelength in mm)."""
    diff = line_minus_areal(results)
    within = diff["difference_db"].abs() <= AGREEMENT_DB
    diff = diff.with_columns(within.alias("within"))
    rows = []
    for (group, e), part in diff.group_by("group", "youngs_modulus", maintain_order=True):
        rows.append({
            "pavement": str(group), "E (MPa)": e / 1e6,
            f"bands within {AGREEMENT_DB} dB (mm)": ", ".join(part.filter(pl.col("within"))["label"]) or "none",
            "bands beyond (mm)": ", ".join(part.filter(~pl.col("within"))["label"]) or "none",
            "largest |difference| (dB)": float(part["difference_db"].abs().max()),
        })
    return pl.DataFrame(rows)


def surface_error_table(results: Results) -> pl.DataFrame:
    """Per pavement and band: the largest estimated numerical error (dB) of the surface runs' line
    and areal levels (bands.parquet ``level_error_db``, from each run's areal pilot). Empty when no
    surface row has an estimate (error budget off)."""
    assert results.surface_bands is not None
    if "level_error_db" not in results.surface_bands.columns:
        return pl.DataFrame()
    bands = results.surface_bands.filter(pl.col("level_error_db").is_not_null()).join(
        surface_groups(results), on="run_id", how="left")
    if bands.height == 0:
        return pl.DataFrame()
    worst = bands.group_by("group", "band", "model").agg(pl.col("label").first(), pl.col("level_error_db").max())
    table = worst.pivot(on="model", index=["group", "band", "label"], values="level_error_db").sort("group", "band")
    return table.select(pl.col("group").alias("pavement"), pl.col("label").alias("band (mm)"),
                        *[pl.col(m).alias(f"{m} model error (dB)") for m in ("line", "areal") if m in table.columns])


def fig_surface_tiles(plt, results: Results):
    """For one tile per pavement: the enveloped surface (mm) and its pressure map (MPa), with colour bars."""
    examples = results.surface_examples
    if examples is None or examples.height == 0:
        return None
    chosen = (surface_groups(results).filter(pl.col("run_id").is_in(examples["run_id"].unique().implode()))
              .group_by("group", maintain_order=True).first())
    # One map per row, the full width: at equal scales a tile 0.5 m long and 40 mm wide is a strip.
    fig, axes = plt.subplots(2 * chosen.height, 1, figsize=(10.0, 1.8 * 2 * chosen.height + 0.4), squeeze=False,
                             layout="constrained")
    for row, (group, run_id) in enumerate(chosen.select("group", "run_id").iter_rows()):
        tile = examples.filter(pl.col("run_id") == run_id).sort("y", "x")
        x, y = np.unique(tile["x"].to_numpy()), np.unique(tile["y"].to_numpy())
        envelope = tile["envelope"].to_numpy().reshape(y.size, x.size)
        pressure = tile["pressure"].to_numpy().reshape(y.size, x.size)
        e = float(tile["youngs_modulus"][0])
        dx, dy = float(x[1] - x[0]), float(y[1] - y[0])
        # roadtex.plot draws the maps, as for a user: equal scales along and across the road
        for ax, values, kind, title in ((axes[2 * row, 0], envelope, "envelope", "enveloped surface"),
                                        (axes[2 * row + 1, 0], pressure, "pressure", "pressure map")):
            plot.surface_map(values, dx, dy, kind=kind, x0=float(x[0]), y0=float(y[0]), ax=ax,
                             title=f"{group}: {title}, {modulus_label(e)}")
    return fig


def fig_line_vs_areal(plt, results: Results):
    """Line − areal enveloped level (dB) per band, one panel per pavement, one curve per E."""
    diff = line_minus_areal(results)
    if diff.height == 0:
        return None
    groups = diff["group"].unique(maintain_order=True).to_list()
    labels = diff.sort("band").select("band", "label").unique(maintain_order=True)
    position = {b: i for i, b in enumerate(labels["band"])}
    fig, axes = plt.subplots(1, len(groups), figsize=(3.4 * len(groups) + 2.0, 3.6), squeeze=False, sharey=True,
                             layout="constrained")
    moduli = sorted(diff["youngs_modulus"].unique().to_list())
    over = over_budget_bands(results, results.surface_bands)
    for column, group in enumerate(groups):
        ax = axes[0, column]
        mark_over_budget(ax, [position[b] for b in over.get(str(group), ()) if b in position])
        for colour, e in zip(COLOURS, moduli):
            rows = diff.filter((pl.col("group") == group) & (pl.col("youngs_modulus") == e))
            ax.plot([position[b] for b in rows["band"]], rows["difference_db"], color=colour, marker=".", lw=1.0,
                    label=modulus_label(e))
        ax.axhspan(-AGREEMENT_DB, AGREEMENT_DB, color="0.9", zorder=0)
        ax.axhline(0, color="0.5", lw=0.7)
        ax.set_xticks(range(labels.height))
        ax.set_xticklabels(labels["label"].to_list(), rotation=90)
        ax.set(title=str(group), xlabel="band, centre wavelength (mm)")
    axes[0, 0].set_ylabel("line − areal enveloped level (dB)")
    legend_outside(fig)
    return fig
