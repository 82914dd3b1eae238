"""The report's profile-level figures (reproducing the seed's figures 2.1, 3.1, 4.1 to 4.3), drawn
from the job's example segments and edge-effect table. Every legend sits outside the axes, so it
never hides data."""

from __future__ import annotations

from typing import Any, Callable

import numpy as np
import polars as pl

import roadtex.plot as plot
from roadtex.comparisons.figures import SEED_D_STAR
from roadtex.plot.profiles import draw_pressure
from roadtex.report.data import COLOURS, MM, Example, legend_outside, megapascals, modulus_label

#: The length of profile the figures show (m), in the middle of the segment.
MIDDLE_WINDOW = 0.1


def middle_window(example: Example, length: float = MIDDLE_WINDOW) -> slice:
    """A window of ``length`` (m) in the middle of the segment, so texture is visible at a glance."""
    n = example.heights.size
    points = min(n, max(8, int(round(length / example.dx))))
    first = (n - points) // 2
    return slice(first, first + points)


def fig_von_meier(plt, examples: list[Example], envelopes: pl.DataFrame):
    """Figure 2.1 from the job's ``von_meier.parquet`` (the first example's run), or None when the
    job wrote no envelope for it."""
    example = examples[0]
    view = middle_window(example)
    table = envelopes.filter((pl.col("run_id") == example.run_id) & (pl.col("index") >= view.start)
                             & (pl.col("index") < view.stop)).sort("d_star", "index")
    if table.height == 0:
        return None
    fig, ax = plt.subplots(figsize=(9, 3.2), layout="constrained")
    first = table.filter(pl.col("d_star") == table["d_star"][0])
    ax.plot(first["x"] * MM, first["height"] * MM, color="0.3", lw=0.8, label="road profile")
    for colour, ((d_star,), rows) in zip(COLOURS, table.group_by("d_star", maintain_order=True)):
        ax.plot(rows["x"] * MM, rows["envelope"] * MM, color=colour, lw=1.1, label=f"d* = {d_star / 1e3:g} 1/mm")
    ax.set(xlabel="distance x (mm)", ylabel="height z (mm)", title=f"von Meier envelopes, {example_title(example)}")
    legend_outside(fig, ax)
    return fig


def fig_edge_effect(plt, table: pl.DataFrame):
    """Figure 3.1 from the job's ``edge_effect.parquet``."""
    modulus, mean_pressure = float(table["youngs_modulus"][0]), float(table["mean_pressure"][0])
    points = table.filter(pl.col("model") == table["model"][0])
    length = float(points["x"].max() + points["x"].min())  # centres run from dx/2 to L - dx/2
    styles = {"finite": (COLOURS[1], "-"), "periodic": (COLOURS[0], "-"), "flat punch (exact)": ("0.4", ":")}
    fig, ax = plt.subplots(figsize=(9, 3.2), layout="constrained")
    for (model,), rows in table.group_by("model", maintain_order=True):
        colour, style = styles.get(model, ("0.5", "--"))
        ax.plot(rows["x"] * MM, rows["pressure"] / 1e6, color=colour, ls=style, label=model)
    ax.set(xlabel="distance x (mm)", ylabel="pressure p (MPa)", ylim=(0, 4 * mean_pressure / 1e6),
           title=f"Flat profile, L = {length * MM:g} mm, {modulus_label(modulus)}, P = {megapascals(mean_pressure)}")
    legend_outside(fig, ax)
    return fig


def example_title(example: Example) -> str:
    """The pavement type and run, or the run alone when the manifest gave no pavement type."""
    return example.group if example.group == example.run_id else f"{example.group} (run {example.run_id})"


def per_group(plt, examples: list[Example], draw: Callable[[Any, Example], None], ylabel: str, title: str):
    fig, axes = plt.subplots(len(examples), 1, figsize=(9, 2.2 * len(examples) + 0.4), squeeze=False, sharex=True,
                             layout="constrained")
    for ax, example in zip(axes[:, 0], examples):
        draw(ax, example)
        ax.set_ylabel(ylabel)
        ax.set_title(example_title(example), loc="left")
    axes[-1, 0].set_xlabel("distance x (mm)")
    legend_outside(fig, axes[0, 0])
    fig.suptitle(title)
    return fig


def fig_envelopes(plt, examples: list[Example]):
    def draw(ax, example: Example) -> None:
        # roadtex.plot draws it, as for a user (one drawing code): the middle 0.1 m of the segment
        plot.profile(example.heights, example.dx, envelope=example.envelopes, window=MIDDLE_WINDOW, ax=ax)

    return per_group(plt, examples, draw, "height (mm)", "Enveloped profiles (INRETS periodic model)")


def fig_pressures(plt, examples: list[Example]):
    def draw(ax, example: Example) -> None:
        view = middle_window(example)
        x = np.arange(example.heights.size)[view] * example.dx * MM
        draw_pressure(ax, x, {e: pressure[view] for e, pressure in example.pressures.items()})

    return per_group(plt, examples, draw, "pressure p (MPa)", "Contact pressure (INRETS periodic model)")


def fig_valley_penetration(plt, examples: list[Example], moduli: list[float], penetration: pl.DataFrame):
    """Figure 4.3 from the job's ``penetration.parquet`` (each example's run)."""
    fig, axes = plt.subplots(1, len(examples), figsize=(3.2 * len(examples) + 2.0, 3.6), squeeze=False,
                             layout="constrained")
    d_star = float(penetration["d_star"][0]) if penetration.height else SEED_D_STAR
    for ax, example in zip(axes[0], examples):
        table = penetration.filter(pl.col("run_id") == example.run_id)
        top = 0.0
        for colour, e in zip(COLOURS, moduli):
            rows = table.filter(pl.col("youngs_modulus") == e)
            ax.scatter(rows["von_meier_penetration"] * MM, rows["inrets_penetration"] * MM, s=10, color=colour,
                       alpha=0.8, label=modulus_label(e))
            if rows.height:
                top = max(top, float(rows["von_meier_penetration"].max()), float(rows["inrets_penetration"].max()))
        ax.plot([0, top * MM], [0, top * MM], color="0.5", lw=0.7, ls=":", label="equal penetration")
        ax.set(xlabel=f"von Meier (d* = {d_star / 1e3:g} 1/mm) penetration (mm)",
               ylabel="INRETS penetration (mm)", title=example.group)
    legend_outside(fig, axes[0, 0])
    return fig
