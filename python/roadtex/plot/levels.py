"""Band levels (original against enveloped, with their stated numerical errors) and speed against
error."""

from __future__ import annotations

import numpy as np
import polars as pl

from roadtex.errors import InvalidInputError
from roadtex.plot.style import COLOURS, TEXTURE_DB, legend_outside, modulus_label, new_axes

BAND_COLUMNS = ("band", "label", "texture_level", "enveloped_level")


def _energetic_mean(column: str) -> pl.Expr:
    """Mean of levels in power (dB): 10 lg(mean 10^(L/10)), over the finite ones."""
    level = pl.col(column).filter(pl.col(column).is_finite())
    return (10.0 * (10.0 ** (level / 10.0)).mean().log10()).alias(column)


def mean_level_error(level: str, error: str) -> pl.Expr:
    """The stated error (dB) of the energetic mean of ``level`` over the rows aggregated, from each
    row's stated ``error`` (dB): 10 lg(sum P 10^(e / 10) / sum P), P = 10^(L / 10), over the rows with
    a finite level and a stated error. Each row's power lies within 10^(+-e / 10) of its own, so the
    mean's lies within this of the mean (the larger side): the rows' errors weighted by their power,
    at most the largest of them. A level stated with a larger error because its band holds little
    power (bands.parquet ``level_error_db``, below its group's typical level) weighs little in the mean."""
    rows = pl.col(level).is_finite() & pl.col(error).is_not_null()
    power = (10.0 ** (pl.col(level) / 10.0)).filter(rows)
    return 10.0 * ((power * 10.0 ** (pl.col(error).filter(rows) / 10.0)).sum() / power.sum()).log10()


def band_levels(bands: pl.DataFrame, *, errors: str | None = "level_error_db", kind: str = "third_octave", ax=None):
    """Texture levels of the original and the enveloped profile per band, and their difference, with
    each level's stated numerical error as an error bar.

    Args:
        bands: a table shaped as the bulk job's ``bands.parquet`` (or a part of it): ``band``,
            ``label``, ``texture_level`` and ``enveloped_level`` (dB re 1 µm), optionally
            ``youngs_modulus`` (Pa; one curve per E), ``reported`` (only reported rows are drawn) and
            the error column. Several rows of one band and E (segments, runs) are averaged in power.
        errors: the column of the levels' stated numerical error (dB), drawn as error bars (that of
            the rows' mean, :func:`mean_level_error`); None, a table without it or with no value in it: no error bars. A
            NaN or infinite error draws no bar, and the count of such rows is written on the axes;
            non-finite levels are left out of the band's mean.
        kind: "third_octave" or "octave", for the band axis' title.
        ax: two axes (levels, difference) to draw into instead of a new figure.

    Returns:
        ``(fig, (levels_ax, difference_ax))``.
    """
    missing = [c for c in BAND_COLUMNS if c not in bands.columns]
    if missing:
        raise InvalidInputError(f"bands table lacks column(s) {missing}; expected those of bands.parquet")
    table = bands.filter(pl.col("reported")) if "reported" in bands.columns else bands
    if "youngs_modulus" not in table.columns:
        table = table.with_columns(pl.lit(None, dtype=pl.Float64).alias("youngs_modulus"))
    # no bars where no level states an error (the budget off): zero-length bars would claim exactness
    unstated = 0
    if errors is not None and errors in table.columns and table[errors].dtype.is_float():
        # an infinite or NaN stated error draws no bar (an infinite bar would fill the axes): counted and said
        unstated = int((table[errors].is_not_null() & ~table[errors].is_finite()).sum())
        table = table.with_columns(pl.when(pl.col(errors).is_finite()).then(pl.col(errors)).alias(errors))
    with_errors = errors is not None and errors in table.columns and table[errors].is_not_null().any()
    stated = ([mean_level_error("enveloped_level", errors).alias("error")] if with_errors
              else [pl.lit(0.0).alias("error")])
    means = (table.group_by("youngs_modulus", "band").agg(pl.col("label").first(), _energetic_mean("texture_level"),
                                                           _energetic_mean("enveloped_level"), *stated)
             .sort("youngs_modulus", "band", nulls_last=True))
    labels = means.select("band", "label").unique("band").sort("band")
    position = {b: b for b in labels["band"]}  # the band number: panels sharing an axis line up
    fig, axes = new_axes(ax, rows=2, figsize=(8.0, 6.0))
    top, bottom = axes[0], axes[1]
    original = means.group_by("band").agg(pl.col("texture_level").first(), pl.col("error").max()).sort("band")
    xs = [position[b] for b in original["band"]]
    top.errorbar(xs, original["texture_level"], yerr=original["error"].fill_null(0.0) if with_errors else None,
                 color="0.2", lw=1.6, capsize=2, label="original")
    for colour, ((e,), rows) in zip(COLOURS, means.group_by("youngs_modulus", maintain_order=True)):
        name = "enveloped" if e is None else modulus_label(e)
        xs = [position[b] for b in rows["band"]]
        yerr = rows["error"].fill_null(0.0).to_numpy() if with_errors else None
        top.errorbar(xs, rows["enveloped_level"], yerr=yerr, color=colour, lw=1.0, capsize=2, label=name)
        # the difference's error: both levels' stated errors, added (they are bounds, not deviations)
        bottom.errorbar(xs, rows["enveloped_level"] - rows["texture_level"], yerr=None if yerr is None else 2 * yerr,
                        color=colour, lw=1.0, marker=".", capsize=2, label=name)
    if unstated:
        top.text(0.01, 0.01, f"{unstated} row(s) with a non-finite stated error: no error bar", transform=top.transAxes,
                 fontsize=7, color="0.35", va="bottom")
    top.set_ylabel(f"texture level L_tx ({TEXTURE_DB})")
    bottom.set_ylabel("enveloped − original level (dB)")
    bottom.axhline(0, color="0.5", lw=0.7)
    bottom.set_xticks(labels["band"].to_list())
    bottom.set_xticklabels(labels["label"].to_list(), rotation=90)
    bottom.set_xlabel(f"{'octave' if kind == 'octave' else 'one-third-octave'} band, centre wavelength (mm)")
    if ax is None:
        legend_outside(fig, top)
    return fig, (top, bottom)


def speed_vs_error(rows, *, ax=None):
    """Time per solve against the relative L1 pressure error, log-log, one colour per solver and one
    marker per case.

    Args:
        rows: a polars DataFrame or a list of dicts with ``solver``, ``case``, ``l1_error`` (1) and
            ``time_s`` (s), as ``benches/speed_vs_error.py --json`` writes them; rows whose time or
            error is missing, zero or not finite (NaN, inf) are left out, and their count is written
            on the axes.
        ax: draw into this axes instead of a new figure.

    Returns:
        ``(fig, ax)``, or ``(None, None)`` when no row has both a time and an error to draw.

    Raises:
        InvalidInputError: rows that are no table, lack a column, or hold text for a number.
    """
    if isinstance(rows, pl.DataFrame):
        table = rows
    else:
        try:
            table = pl.DataFrame(list(rows), infer_schema_length=None)
        except (TypeError, ValueError, pl.exceptions.PolarsError) as exc:
            raise InvalidInputError(f"speed rows must be a table or a list of objects with solver, case, l1_error and "
                                    f"time_s: {str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__}") from None
    needed = {"solver", "case", "l1_error", "time_s"}
    if table.height and not needed <= set(table.columns):
        raise InvalidInputError(f"speed rows lack column(s) {sorted(needed - set(table.columns))}")
    for column in ("l1_error", "time_s"):
        if table.height and not (table[column].dtype.is_numeric() or table[column].dtype == pl.Null):
            raise InvalidInputError(f"speed rows' {column} must be numbers, got {table[column].dtype}")
    given = table.height
    if table.height:   # a log-log axis draws positive, finite values only: the others are counted and said
        drawable = (pl.col("time_s").is_finite() & (pl.col("time_s") > 0)
                    & pl.col("l1_error").is_finite() & (pl.col("l1_error") > 0))
        table = table.filter(drawable.fill_null(False))
    if table.height == 0:
        return None, None
    fig, ax = new_axes(ax, figsize=(8.0, 4.2))
    if given > table.height:
        ax.text(0.01, 0.01, f"{given - table.height} of {given} rows not drawn: time or error missing, zero or not "
                "finite", transform=ax.transAxes, fontsize=7, color="0.35", va="bottom")
    markers = {"westergaard": "o", "self_affine": "s"}
    for colour, ((solver,), group) in zip(COLOURS, table.group_by("solver", maintain_order=True)):
        for (case,), sub in group.group_by("case", maintain_order=True):
            ax.scatter(sub["l1_error"], sub["time_s"], color=colour, marker=markers.get(case, "^"), s=18,
                       label=f"{solver} ({case})")
    ax.set(xscale="log", yscale="log", xlabel="relative L1 pressure error", ylabel="time per solve (s)")
    if np.isfinite(table["l1_error"].to_numpy()).any() and ax.get_legend_handles_labels()[0]:
        legend_outside(fig, ax)
    return fig, ax
