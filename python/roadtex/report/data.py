"""What the report reads: the job's tables, nothing else (never the raw files, never a new solve)."""

from __future__ import annotations

import hashlib
import io
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from roadtex.errors import DamagedResultsError, InvalidInputError, ResultsNotFoundError
from roadtex.plot.levels import mean_level_error

# The figures' shared style is roadtex.plot's (one drawing code for the report and for users);
# re-exported here for the report's modules.
from roadtex.plot.style import (  # noqa: F401
    COLOURS,
    MM,
    MPA,
    PRESSURE_DB,
    TEXTURE_DB,
    legend_outside,
    megapascals,
    modulus_label,
    plain,
)


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"figure.dpi": 110, "axes.grid": True, "grid.alpha": 0.3, "font.size": 9,
                         "axes.titlesize": 10, "legend.fontsize": 8, "svg.fonttype": "none"})
    return plt


def save_png_and_svg(fig: Any, svg_path: Path) -> bytes:
    """Writes ``fig`` to ``svg_path`` and returns it as PNG bytes (for the page).

    Every report figure has a constrained layout, which keeps legends, titles and labels inside the
    figure (legends outside the axes too: ``loc="outside ..."``), so the files are not cropped to
    what is drawn: a tight crop draws each figure twice more. The layout is worked out once, by the
    PNG's draw, and kept for the SVG (the report's time on the demo's figures: 20 s -> 9 s). The
    engine is removed for the SVG, not swapped for the "none" placeholder: matplotlib runs a layout
    pass (a whole draw) before saving a figure with any engine set, the placeholder too (the demo's
    report: 33 draws instead of 44, 14.0-14.7 s instead of 16.6-18.1; the same files, dates aside).
    """
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    fig.set_layout_engine(None)
    fig.savefig(svg_path, format="svg")
    return buffer.getvalue()


SUPERSCRIPTS = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def tolerance(value: float) -> str:
    """A solver tolerance as people write it, never with an exponent: an exact power of ten from
    10⁻⁴ down as "10⁻⁸", anything else positional to 3 significant digits (2.5e-6 -> "0.0000025"); "n/a" when missing."""
    if value is None or not np.isfinite(value) or value <= 0:
        return "n/a" if value is None or np.isnan(value) else plain(value)
    power = round(float(np.log10(value)))
    if power <= -4 and abs(value / 10.0 ** power - 1.0) < 1e-9:
        return f"10{str(power).translate(SUPERSCRIPTS)}"
    return plain(value)


#: The legend entry of the bands marked by :func:`mark_over_budget`.
OVER_BUDGET_LABEL = "band whose stated error exceeds the budget"

#: The legend entry of the bands marked by :func:`mark_over_budget` with ``surfaces=True``: over
#: the budget in a pavement's surface runs only (its profile runs within it, or none).
SURFACE_OVER_BUDGET_LABEL = "band over the budget in surface runs only"

#: Which runs :func:`over_budget_bands` looks at: every run, the profile (line) runs, or the
#: surface (3D) runs.
RUN_KINDS = ("all", "profiles", "surfaces")


def surface_run_ids(results: "Results") -> set[str]:
    """The runs of ``results`` that are surfaces (3D texture: they have areal rows)."""
    if results.surface_bands is None:
        return set()
    return {str(r) for r in results.surface_bands["run_id"].unique().to_list()}


def over_budget_bands(results: "Results", bands: pl.DataFrame | None = None, runs: str = "all") -> dict[str, set[int]]:
    """Per group (:meth:`Results.run_groups`), the bands whose group mean's stated numerical error
    exceeds the job's error budget for some modulus, over the group's runs of kind ``runs``
    (:data:`RUN_KINDS`: a pavement's profile runs and its surface runs are solved on different grids
    and state their errors apart, so a figure marks them apart): the figures draw the group's mean
    levels, which may then be off by more than the budget, and every figure drawing them marks them.
    The mean's error comes from each level's (bands.parquet ``level_error_db``) weighted by its
    power, the larger of the enveloped and pressure weights (:func:`roadtex.plot.levels.mean_level_error`):
    a level stated with a larger error because its band holds little power in its segment moves the
    mean little. Empty without a budget or without error estimates."""
    if runs not in RUN_KINDS:
        raise ValueError(f"runs must be one of {RUN_KINDS}, got {runs!r}")
    budget = results.options.get("error_budget_db")
    table = results.bands if bands is None else bands
    if budget is None or "level_error_db" not in table.columns:
        return {}
    if runs != "all":
        surfaces = pl.Series(sorted(surface_run_ids(results)), dtype=pl.String).implode()
        inside = pl.col("run_id").cast(pl.String).is_in(surfaces)
        table = table.filter(inside if runs == "surfaces" else ~inside)
    levels = [c for c in ("enveloped_level", "pressure_level") if c in table.columns]
    keys = [c for c in ("youngs_modulus", "model") if c in table.columns]
    stated = table.filter(pl.col("level_error_db").is_not_null()).join(results.run_groups(), on="run_id", how="left")
    stated = stated.with_columns(pl.col("group").fill_null(pl.col("run_id")))
    if levels:
        means = stated.group_by("group", "band", *keys).agg(
            pl.max_horizontal(*[mean_level_error(c, "level_error_db") for c in levels]).alias("mean_error_db"))
    else:   # a table without levels: its rows' errors as they are
        means = stated.select("group", "band", pl.col("level_error_db").alias("mean_error_db"))
    over = means.filter(pl.col("mean_error_db") > budget)
    marked: dict[str, set[int]] = {}
    for group, band in over.select("group", "band").iter_rows():
        marked.setdefault(str(group), set()).add(int(band))
    return marked


def mark_over_budget(ax: Any, positions: list[float], surfaces: bool = False) -> None:
    """Hatches the band positions ``positions`` (x, one unit wide) of ``ax``: levels whose stated
    error exceeds the budget (labelled :data:`OVER_BUDGET_LABEL` once, for the legend); with
    ``surfaces``, bands over it in a pavement's surface runs only, marked apart (orange dots: the
    grey back-hatch is the sampling-limited bands'; :data:`SURFACE_OVER_BUDGET_LABEL`)."""
    colour, hatch, label, gid = (("#ff7f0e", "..", SURFACE_OVER_BUDGET_LABEL, "over_budget_surfaces") if surfaces
                                 else ("#d62728", "///", OVER_BUDGET_LABEL, "over_budget"))
    for index, x in enumerate(sorted(positions)):
        ax.axvspan(x - 0.5, x + 0.5, facecolor="none", edgecolor=colour, hatch=hatch, lw=0, alpha=0.5, zorder=0,
                   label=label if index == 0 else None, gid=gid)


def power_mean_db(levels: pl.Expr) -> pl.Expr:
    """Mean of levels in power (dB): 10 lg(mean 10^(L/10))."""
    return 10.0 * (10.0 ** (levels / 10.0)).mean().log10()


@dataclass
class Results:
    root: Path
    segments: pl.DataFrame
    bands: pl.DataFrame
    runs: pl.DataFrame
    errors: pl.DataFrame
    examples: pl.DataFrame
    edge_effect: pl.DataFrame
    parameters: dict[str, Any]
    #: pilot.parquet (empty when the job ran with the error budget off; None when the folder has no
    #: such file: written by a roadtex before the error budget).
    pilot: pl.DataFrame | None = None
    #: surface runs' band rows of both models ("line" and "areal"; reported bands only) and their
    #: middle tiles (surface_examples.parquet); None when the results hold no areal row.
    surface_bands: pl.DataFrame | None = None
    surface_examples: pl.DataFrame | None = None
    #: the job's von Meier envelopes (von_meier.parquet) and valley penetration table
    #: (penetration.parquet) of each run's example segment: what figures 2.1 and 4.3 draw.
    von_meier: pl.DataFrame | None = None
    penetration: pl.DataFrame | None = None

    @property
    def options(self) -> dict[str, Any]:
        return self.parameters.get("options", {})

    @property
    def plan(self) -> dict[str, Any]:
        """parameters.json's ``plan`` (how the job chose dx and tol, and its error estimates); empty
        when the folder has none."""
        return self.parameters.get("plan") or {}

    @property
    def moduli(self) -> list[float]:
        return sorted(self.segments["youngs_modulus"].unique().to_list())

    def run_groups(self) -> pl.DataFrame:
        """One row per run: ``run_id`` and ``group``, the run's pavement type when the manifest gave
        one, else the run id itself."""
        column = self.group_column()
        return (self.segments.select("run_id", pl.col(column).cast(pl.String).alias("group"))
                .unique(subset="run_id", maintain_order=True))

    def group_column(self) -> str:
        """Pavement type when the manifest gave it, else the run id."""
        if self.segments["pavement"].null_count() < self.segments.height:
            return "pavement"
        return "run_id"


def failures_said(errors_path: Path, most: int = 5) -> str:
    """The failed runs of errors.parquet as the message of a report that cannot be drawn: each run
    and why (its message names the file), the first ``most`` of them."""
    if not errors_path.is_file():
        return ""
    errors = pl.read_parquet(errors_path, columns=["run_id", "stage", "message"])
    if errors.height == 0:
        return " (errors.parquet lists no failure)"
    listed = "; ".join(f"{r['run_id']} ({r['stage']}): {r['message']}" for r in errors.head(most).iter_rows(named=True))
    more = f"; and {errors.height - most} more" if errors.height > most else ""
    return f". errors.parquet: {listed}{more}"


def load_results(results_dir: Path) -> Results:
    """The tables of a results folder written by :func:`roadtex.process`."""
    needed = ("segments.parquet", "bands.parquet", "runs.parquet", "examples.parquet", "edge_effect.parquet",
              "von_meier.parquet", "penetration.parquet", "parameters.json")
    missing = [name for name in needed if not (results_dir / name).exists()]
    if missing:
        raise ResultsNotFoundError(f"{results_dir} is not a roadtex results folder: missing {', '.join(missing)} "
                                "(run `roadtex process MANIFEST --out DIR` first, with this version of roadtex)")
    verify_checksums(results_dir)
    try:
        return read_results(results_dir)
    except (pl.exceptions.PolarsError, OSError, ValueError) as exc:
        if isinstance(exc, (ResultsNotFoundError, InvalidInputError)):
            raise
        raise DamagedResultsError(f"{results_dir}: a table of the job cannot be read ({type(exc).__name__}: "
                                  f"{str(exc)[:200]}); process the manifest again to rebuild it") from None


def verify_checksums(results_dir: Path) -> None:
    """Refuses a results folder whose tables differ from the checksums the job recorded in
    parameters.json when it wrote them (a table damaged or changed since would be drawn as data)."""
    try:
        recorded = json.loads((results_dir / "parameters.json").read_text(encoding="utf-8")).get("checksums") or {}
    except (OSError, ValueError, AttributeError) as exc:
        raise DamagedResultsError(f"{results_dir}/parameters.json cannot be read: {str(exc)[:200]}") from None
    for name, digest in recorded.items():
        if not (results_dir / name).exists():
            continue   # the tables the report needs were checked above; an optional one is drawn without
        digester = hashlib.sha256()
        try:
            with open(results_dir / name, "rb") as stream:
                for block in iter(lambda s=stream: s.read(1 << 20), b""):
                    digester.update(block)
        except OSError as exc:
            raise DamagedResultsError(f"{results_dir}/{name} cannot be read: {exc.strerror or exc}") from None
        if digester.hexdigest() != digest:
            raise DamagedResultsError(f"{results_dir}/{name} is not the table the job wrote (its checksum differs "
                                      "from the one in parameters.json: changed or damaged since); process the "
                                      "manifest again to rebuild it from the runs' files")


def read_results(results_dir: Path) -> Results:
    """The tables of a results folder, read (checked by :func:`load_results`)."""
    segments = pl.read_parquet(results_dir / "segments.parquet")
    if segments.height == 0:
        raise InvalidInputError(f"{results_dir}/segments.parquet has no rows: every run failed, so there is "
                                f"nothing to report{failures_said(results_dir / 'errors.parquet')}")
    errors_path = results_dir / "errors.parquet"
    pilot_path = results_dir / "pilot.parquet"
    bands = read_reported_bands(results_dir / "bands.parquet")
    surface_bands = surface_examples = None
    if "model" in bands.columns and (bands["model"] == "areal").any():
        areal_runs = bands.filter(pl.col("model") == "areal")["run_id"].unique()
        surface_bands = bands.filter(pl.col("run_id").is_in(areal_runs.implode()))
        example_path = results_dir / "surface_examples.parquet"
        surface_examples = pl.read_parquet(example_path) if example_path.exists() else None
    if "model" in segments.columns:
        # the seed's figures and the run tables show the line model (surface runs: on their lines)
        segments = segments.filter(pl.col("model") == "line")
        bands = bands.filter(pl.col("model") == "line")
    return Results(results_dir, segments, bands,
                   pl.read_parquet(results_dir / "runs.parquet"),
                   pl.read_parquet(errors_path) if errors_path.exists() else pl.DataFrame(),
                   pl.read_parquet(results_dir / "examples.parquet"),
                   pl.read_parquet(results_dir / "edge_effect.parquet"),
                   json.loads((results_dir / "parameters.json").read_text(encoding="utf-8")),
                   pl.read_parquet(pilot_path) if pilot_path.exists() else None, surface_bands, surface_examples,
                   pl.read_parquet(results_dir / "von_meier.parquet"), pl.read_parquet(results_dir / "penetration.parquet"))


@dataclass
class Example:
    """One representative segment of a pavement, solved at every modulus of the job."""

    group: str
    run_id: str
    dx: float
    heights: np.ndarray
    envelopes: dict[float, np.ndarray]
    pressures: dict[float, np.ndarray]


def load_examples(results: Results, max_groups: int = 4) -> list[Example]:
    """The example segment (each run's middle segment, solved by the job at every modulus) of the
    first run of each pavement type (or run), read from ``examples.parquet``."""
    with_example = results.examples["run_id"].unique().implode()
    chosen = (results.run_groups().filter(pl.col("run_id").is_in(with_example))
              .group_by("group", maintain_order=True).first().head(max_groups))
    examples = []
    for group, run_id in chosen.select("group", "run_id").iter_rows():
        rows = results.examples.filter(pl.col("run_id") == run_id).sort("youngs_modulus", "position")
        if rows.height == 0:
            continue
        moduli = rows["youngs_modulus"].unique(maintain_order=True).to_list()
        first = rows.filter(pl.col("youngs_modulus") == moduli[0])
        examples.append(Example(
            str(group), run_id, float(first["dx"][0]), first["height"].to_numpy(),
            {e: rows.filter(pl.col("youngs_modulus") == e)["envelope"].to_numpy() for e in moduli},
            {e: rows.filter(pl.col("youngs_modulus") == e)["pressure"].to_numpy() for e in moduli}))
    return examples


def read_reported_bands(path: Path) -> pl.DataFrame:
    """bands.parquet's reported bands (the table keeps every band, with ``reported`` and ``reason``)."""
    bands = pl.read_parquet(path)
    return bands.filter(pl.col("reported")) if "reported" in bands.columns else bands
