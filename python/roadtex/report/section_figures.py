"""The report's part on indicators along the road: for the long line runs (at least
:data:`MIN_SECTIONS` sections), MPD per section and one band level per section against chainage,
from sections.parquet and section_bands.parquet (:mod:`roadtex.archive.sections`). Reads only those
tables; nothing when the job wrote none (an archive of an older roadtex) or no run is long enough."""

from __future__ import annotations

import base64
import html
from pathlib import Path

import numpy as np
import polars as pl

from roadtex.report.data import COLOURS, MM, TEXTURE_DB, legend_outside, pyplot, save_png_and_svg

#: A run with at least this many sections is "long": its indicators are drawn along the road.
MIN_SECTIONS = 3
#: The band drawn: the enveloped texture level in the reported band nearest this wavelength (m),
#: whose tyre/road noise lies near 1 kHz at 70 to 80 km/h.
BAND_WAVELENGTH = 20e-3
#: At most this many runs are drawn (the longest ones), so the figure stays readable.
MAX_RUNS = 6


def long_runs(sections: pl.DataFrame) -> list[str]:
    """The run ids with at least :data:`MIN_SECTIONS` sections, longest first (at most :data:`MAX_RUNS`)."""
    counts = sections.group_by("run_id").agg(pl.len().alias("n"), pl.col("length").sum().alias("total"))
    keep = counts.filter(pl.col("n") >= MIN_SECTIONS).sort("total", "run_id", descending=[True, False])
    return keep["run_id"].head(MAX_RUNS).to_list()


def chosen_band(section_bands: pl.DataFrame) -> pl.DataFrame:
    """The rows of the reported band nearest :data:`BAND_WAVELENGTH` at the middle modulus, per run."""
    moduli = sorted(set(section_bands["youngs_modulus"].to_list()))
    middle = moduli[len(moduli) // 2]
    rows = section_bands.filter(pl.col("reported") & (pl.col("youngs_modulus") == middle))
    nearest = (rows.select("run_id", "band", "centre_wavelength").unique()
               .with_columns((pl.col("centre_wavelength").log() - np.log(BAND_WAVELENGTH)).abs().alias("distance"))
               .sort("run_id", "distance").group_by("run_id", maintain_order=True).first().select("run_id", "band"))
    return rows.join(nearest, on=["run_id", "band"])


def fig_sections(plt, sections: pl.DataFrame, section_bands: pl.DataFrame, runs: list[str]):
    """MPD (mm, valid sections filled, invalid ones open) and the chosen band's enveloped level per
    section against the section's mid chainage (m), one colour per run."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.5, 4.8), sharex=False, layout="constrained")
    band = chosen_band(section_bands)
    for colour, run_id in zip(COLOURS, runs):
        part = sections.filter(pl.col("run_id") == run_id).sort("section")
        middle = 0.5 * (part["start"].to_numpy() + part["end"].to_numpy())
        depth = part["mpd"].to_numpy().astype(float) * MM
        valid = part["mpd_valid"].to_numpy()
        top.plot(middle, depth, "-", color=colour, lw=1, label=run_id)
        top.plot(middle[valid], depth[valid], "o", color=colour, ms=3)
        top.plot(middle[~valid], depth[~valid], "o", mfc="none", color=colour, ms=3)
        levels = band.filter(pl.col("run_id") == run_id).sort("section")
        if levels.height:
            label = levels["label"][0]
            bottom.plot(0.5 * (levels["start"].to_numpy() + levels["end"].to_numpy()),
                        levels["enveloped_level"].to_numpy().astype(float), "-o", color=colour, ms=3, lw=1,
                        label=f"{run_id} ({label} mm)")
    top.set_ylabel("MPD (mm)")
    bottom.set_ylabel(f"enveloped level\n({TEXTURE_DB})")
    bottom.set_xlabel("chainage (m, as in the file)")
    top.set_xlabel("chainage (m, as in the file)")
    legend_outside(fig, [top, bottom])
    return fig


def sections_part(root: Path, figures_dir: Path) -> list[str]:
    """The report's HTML for the indicators along the road (nothing when there is nothing to draw);
    writes the figure as ``figures_dir/sections.png`` and ``.svg``."""
    path, bands_path = root / "sections.parquet", root / "section_bands.parquet"
    if not path.exists() or not bands_path.exists():
        return []
    sections = pl.read_parquet(path)
    runs = long_runs(sections) if sections.height else []
    if not runs:
        return []
    length = float(sections["length"].max())
    plt = pyplot()
    fig = fig_sections(plt, sections, pl.read_parquet(bands_path), runs)
    png_bytes = save_png_and_svg(fig, figures_dir / "sections.svg")
    (figures_dir / "sections.png").write_bytes(png_bytes)
    plt.close(fig)
    caption = html.escape(
        f"Indicators along the road, per section of {length:g} m (sections.parquet), for the runs of at least "
        f"{MIN_SECTIONS} sections: MPD (ISO 13473-1; open markers: fewer than half the section's baselines valid) "
        f"and the enveloped texture level at the job's middle E in the reported band nearest "
        f"{BAND_WAVELENGTH * MM:g} mm, energy-averaged over the contact segments starting in each section.")
    data = base64.b64encode(png_bytes).decode("ascii")
    return ["<h2>Indicators along the road</h2>",
            f'<figure id="sections"><img alt="{caption}" src="data:image/png;base64,{data}"/>'
            f"<figcaption>{caption}</figcaption></figure>"]
