"""The report's account of the error budget (issue 15): the speed-against-error figure of every
setting the job's pilots evaluated, and the table of the numerical error of each band.

Both read only what the job wrote: ``pilot.parquet`` (one row per group, setting and band),
``parameters.json``'s ``plan`` (the job's dx and tol, the budget, the error estimate of each band,
the speed-up and the pilots' time) and, for band labels when the pilot is missing, ``bands.parquet``.
A job run with the budget off (empty pilot) or a results folder from before the budget (no
pilot.parquet) still gets the figure and the section, saying why there is nothing to show.
"""

from __future__ import annotations

import html
import textwrap

import numpy as np
import polars as pl

from roadtex.budget.noise import NOISE_FREQUENCY_RANGE, NOISE_SPEED_RANGE_KMH, noise_wavelength_range
from roadtex.report.data import COLOURS, MM, Results, legend_outside, plain, tolerance

#: Seconds per metre to seconds per km.
KM = 1e3


def setting_points(pilot: pl.DataFrame) -> pl.DataFrame:
    """One row per group and setting of ``pilot.parquet``: ``group``, ``dx`` (m), ``tol``,
    ``points``, ``chosen``, ``reference``, ``worst_error_db`` (the largest ``level_error_db`` over
    the budget bands, dB; inf when one of them is not reported at that dx) and ``seconds_per_km``
    (measured solve time for every modulus per km of road, s/km), in the order the pilot wrote them."""
    return (pilot.group_by("group", "dx", "tol", maintain_order=True)
            .agg(pl.col("points").first(), pl.col("chosen").any(), pl.col("reference").any(),
                 pl.col("level_error_db").filter(pl.col("in_budget")).max().alias("worst_error_db"),
                 (pl.col("seconds_per_metre").first() * KM).alias("seconds_per_km")))


def pilot_state(results: Results) -> str | None:
    """Why there are no settings to show (a sentence), or None when the pilot has rows."""
    if results.pilot is None:
        return ("No pilot was recorded: this results folder has no pilot.parquet (written by a roadtex "
                "before the error budget), so no candidate setting can be shown.")
    if results.pilot.height == 0:
        plan = results.plan
        budget = (results.parameters.get("options") or {}).get("error_budget_db")
        if budget is not None and results.surface_bands is not None:
            # a budget, but no line run for the job's pilot: the surface runs have their own
            return (f"No line-run pilot: the job's error budget ({plain(budget)} dB) had no line run to study. "
                    "The surface runs carry their own areal pilots' estimates and tolerances (the table of "
                    "the 3D-surfaces section; runs.parquet worst_level_error_db, tol_used).")
        if budget is not None:
            return ("No pilot: the job had an error budget but no pilot could run (parameters.json plan: "
                    "failed_pilots, unread_runs), so no level carries an error estimate.")
        setting = ""
        if plan.get("dx") is not None:
            setting = f" (every run solved at dx = {plain(plan['dx'] * MM)} mm, tol = {tolerance(plan.get('tol'))})"
        return (f"No pilot: the job ran with the error budget off{setting}, so no candidate setting was "
                "evaluated and no level carries an error estimate.")
    return None


def fig_setting_speed_vs_error(plt, results: Results):
    """Per group (device / pavement), every (dx, tol) setting the pilot evaluated: time per km
    (s/km) against the worst level error in the budget bands (dB), both logarithmic; the chosen
    setting a star, the finest setting a square (at its own estimated error: it is no error-free
    reference), settings without an error in every budget band a triangle at the right edge, the
    budget a dashed vertical line. Without a pilot, one empty pair of axes saying why."""
    reason = pilot_state(results)
    if reason is not None:
        fig, ax = plt.subplots(figsize=(7.5, 3.6), layout="constrained")
        ax.set(xscale="log", yscale="log", xlim=(1e-3, 10.0), ylim=(1.0, 1e4), title="Speed against error",
               xlabel="worst estimated numerical error in the tyre/road noise bands (dB)",
               ylabel="solve time per km of road (s/km)")
        ax.text(0.5, 0.5, "\n".join(textwrap.wrap(reason, 70)), transform=ax.transAxes, ha="center", va="center",
                fontsize=9, bbox={"boxstyle": "round", "facecolor": "#fff8e0", "edgecolor": "0.6"})
        plain_log_axes(ax)
        return fig
    points = setting_points(results.pilot)
    groups = points["group"].unique(maintain_order=True).to_list()
    tols = sorted(points["tol"].unique().to_list())
    colour_of = {t: COLOURS[i % len(COLOURS)] for i, t in enumerate(tols)}
    columns = min(3, len(groups))
    rows = int(np.ceil(len(groups) / columns))
    fig, axes = plt.subplots(rows, columns, figsize=(4.2 * columns + 4.2, 3.6 * rows + 0.9), squeeze=False,
                             sharex=True, sharey=True, layout="constrained")
    for ax in axes.ravel()[len(groups):]:
        ax.set_visible(False)
    budget = results.plan.get("budget_db")
    for ax, group in zip(axes.ravel(), groups):
        mine = points.filter(pl.col("group") == group)
        drawn = mine.filter(pl.col("worst_error_db").is_finite() & (pl.col("worst_error_db") > 0))
        for t in tols:
            line = drawn.filter(pl.col("tol") == t).sort("dx")
            if line.height:
                ax.plot(line["worst_error_db"], line["seconds_per_km"], color=colour_of[t], lw=0.8, marker="o",
                        ms=4, label=f"candidate, tol = {tolerance(t)}")
        for row in drawn.iter_rows(named=True):
            # the finest setting is what the others are compared with, not an error-free answer: it
            # carries its own estimated error (the data's sampling), shown where it lies
            text = plain(row["dx"] * MM) + (" finest" if row["reference"] else "")
            ax.annotate(text, (row["worst_error_db"], row["seconds_per_km"]), xytext=(4, 3),
                        textcoords="offset points", fontsize=6 if not row["reference"] else 7,
                        color="0.35" if not row["reference"] else "0.1")
        reference = drawn.filter(pl.col("reference"))
        if reference.height:
            ax.scatter(reference["worst_error_db"], reference["seconds_per_km"], s=90, marker="s",
                       facecolors="none", edgecolors="0.25", lw=1.2, zorder=4,
                       label="finest setting evaluated (its own error: the data's sampling)")
        unreported = mine.filter(~(pl.col("worst_error_db").is_finite() & (pl.col("worst_error_db") > 0)))
        if unreported.height:
            # settings whose dx does not report every budget band have no finite worst error: drawn at
            # the right edge (their time is measured), so the panel shows every setting evaluated
            edge = ax.get_yaxis_transform()
            ax.scatter([1.0] * unreported.height, unreported["seconds_per_km"], transform=edge, marker=">", s=30,
                       color="0.45", clip_on=False, zorder=4, label="not every budget band reported at its dx")
            for row in unreported.iter_rows(named=True):
                ax.annotate(plain(row["dx"] * MM), (1.0, row["seconds_per_km"]), xycoords=edge, xytext=(-4, 3),
                            textcoords="offset points", fontsize=6, color="0.35", ha="right")
        chosen = drawn.filter(pl.col("chosen"))
        if chosen.height:
            ax.scatter(chosen["worst_error_db"], chosen["seconds_per_km"], s=160, marker="*", color="#d62728",
                       edgecolors="k", lw=0.6, zorder=5, label="chosen setting", gid="chosen")
        if budget is not None:
            ax.axvline(budget, color="k", ls="--", lw=1.0, label=f"error budget ({plain(budget)} dB)")
        finest = mine.filter(pl.col("reference"))
        if mine["dx"].n_unique() == 1 and finest.height:
            # one sampling interval tried: say why the panel holds so few points, and what they mean
            floor = finest["worst_error_db"][0]
            verdict = (f"already {plain(floor)} dB, over the budget: a coarser dx would only add to it"
                       if budget is not None and floor > budget else f"{plain(floor)} dB")
            note = (f"{mine.height} setting(s), one dx ({plain(finest['dx'][0] * MM)} mm, the data's): its error "
                    f"at the finest tolerance is {verdict}; only the tolerance was varied")
        else:
            note = ""
        # the note under the title, where no point can lie
        ax.set_title("\n".join([*textwrap.wrap(str(group), 45), *setting_lines(mine), *textwrap.wrap(note, 40)]),
                     fontsize=9)
        ax.set(xscale="log", yscale="log")
        ax.margins(x=0.12, y=0.12)
    plain_log_axes(axes[0, 0])
    for ax in axes[-1]:
        ax.set_xlabel("worst estimated numerical error\nin the tyre/road noise bands (dB)")
    for ax in axes[:, 0]:
        ax.set_ylabel("solve time per km of road,\nevery modulus (s/km)")
    legend_outside(fig, title="points labelled with dx (mm)")
    return fig


def setting_lines(settings: pl.DataFrame) -> list[str]:
    """["chosen: dx 0.0375 mm, tol 10⁻⁴", "finest: dx 0.0375 mm, tol 10⁻¹⁰"] for one group's settings."""
    parts = []
    for flag, name in (("chosen", "chosen"), ("reference", "finest")):
        rows = settings.filter(pl.col(flag))
        if rows.height:
            parts.append(f"{name}: dx {plain(rows['dx'][0] * MM)} mm, tol {tolerance(rows['tol'][0])}")
    return parts


def plain_log_axes(ax) -> None:
    """Ticks of a log-log axes (and those shared with it) at 1, 2, 5 x 10^k, written plainly (0.2, 5, 100)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(FuncFormatter(lambda value, _: plain(value)))
        axis.set_minor_formatter(NullFormatter())


def error_rows(results: Results) -> pl.DataFrame:
    """The plan's bands: ``band``, ``label``, ``centre_wavelength`` (m), ``in_budget`` and
    ``plan_error_db`` (parameters.json's estimate at the job's setting, dB), from pilot.parquet's
    band facts (bands.parquet's when there is no pilot)."""
    estimates = {int(b): float(e) for b, e in (results.plan.get("band_error_db") or {}).items()}
    table = pl.DataFrame({"band": list(estimates), "plan_error_db": list(estimates.values())},
                         schema={"band": pl.Int64, "plan_error_db": pl.Float64})
    if results.pilot is not None and results.pilot.height:
        facts = results.pilot.group_by("band").agg(pl.col("label").first(), pl.col("centre_wavelength").first(),
                                                   pl.col("in_budget").any())
    else:
        facts = results.bands.group_by("band").agg(pl.col("label").first(), pl.col("centre_wavelength").first(),
                                                   pl.lit(None, dtype=pl.Boolean).alias("in_budget"))
    return table.join(facts, on="band", how="left").sort("band")


def error_text(value: float | None) -> str:
    if value is None or np.isnan(value):
        return "n/a"
    return plain(value) if np.isfinite(value) else "not reported at this dx"


def band_error_table(results: Results) -> pl.DataFrame:
    """The table "numerical error per band": per band of the plan, its label and centre wavelength
    (mm), whether the budget applies to it, the plan's estimated error at the job's setting (dB) and,
    per pilot group, the estimated error at that group's chosen setting (dB). Empty without a plan
    estimate (budget off)."""
    rows = error_rows(results)
    table = rows.select(
        pl.col("label").alias("band (mm)"), (pl.col("centre_wavelength") * MM).alias("centre wavelength (mm)"),
        pl.col("in_budget").alias("in budget"),
        pl.col("plan_error_db").map_elements(error_text, return_dtype=pl.String)
        .alias("estimated error at the job's setting (dB)"))
    if results.pilot is None or results.pilot.height == 0:
        return table
    chosen = results.pilot.filter(pl.col("chosen")).group_by("group", "band", maintain_order=True).agg(
        pl.col("level_error_db").max())
    for group in results.pilot["group"].unique(maintain_order=True).to_list():
        errors = dict(chosen.filter(pl.col("group") == group).select("band", "level_error_db").iter_rows())
        table = table.with_columns(pl.Series(f"at the chosen setting of {group} (dB)",
                                             [error_text(errors.get(b)) for b in rows["band"]], dtype=pl.String))
    return table


def floor_db(results: Results) -> tuple[float | None, str | None]:
    """The smallest worst-band error any evaluated setting reaches, for the group where that is
    largest (the budget the data's sampling allows), and that group; (None, None) without a pilot."""
    if results.pilot is None or results.pilot.height == 0:
        return None, None
    best = setting_points(results.pilot).group_by("group").agg(pl.col("worst_error_db").min()).sort(
        "worst_error_db", descending=True)
    return float(best["worst_error_db"][0]), str(best["group"][0])


def budget_summary(results: Results) -> str:
    """The section's paragraphs (HTML): budget, dx and tol used, the verdict, the speed-up against
    the finest setting and the pilots' measured time; what the budget could not reach, plainly."""
    plan = results.plan
    reason = pilot_state(results)
    if plan.get("budget_db") is None:
        return f"<p>{html.escape(reason or 'No error budget on record.')}</p>"
    shortest, longest = noise_wavelength_range()
    (f_low, f_high), (v_low, v_high) = NOISE_FREQUENCY_RANGE, NOISE_SPEED_RANGE_KMH
    within = plan.get("within_budget")
    surfaces = ("; surface runs at their own spacings and the tolerance their own pilot chose (runs.parquet "
                "dx_used, tol_used)" if results.surface_bands is not None else "")
    text = [
        f"Error budget {plain(plan['budget_db'])} dB on every level (texture, enveloped texture, contact pressure) "
        f"in the tyre/road noise bands (those marked “in budget” below: reported, and overlapping {plain(f_low)} Hz to "
        f"{plain(f_high / 1e3)} kHz at {plain(v_low)} to {plain(v_high)} km/h, wavelengths {plain(shortest * MM)} "
        f"to {plain(longest * MM)} mm). "
        f"Every line run was solved at dx = {plain(plan['dx'] * MM)} mm and tol = {tolerance(plan['tol'])} "
        f"({html.escape(str(plan.get('source', '')))}){surfaces}. "
        f"Within budget: {'yes' if within else 'no'}; worst estimated error in the budget bands "
        f"{plain(plan.get('worst_error_db') or float('nan'))} dB."]
    if plan.get("speedup") is not None:
        text.append(
            f" Speed-up against the finest setting (the file's sampling, tightest tolerance): "
            f"{plain(plan['speedup'])} times less solver work (iterations × N log₂ N per metre, counted by the "
            f"pilots, so the same data always gives the same choice). Measured by the pilots: "
            f"{plain((plan.get('seconds_per_metre') or float('nan')) * KM)} s per km at the chosen setting against "
            f"{plain((plan.get('finest_seconds_per_metre') or float('nan')) * KM)} s per km at the finest "
            f"(every modulus; the machine's load moves these); the pilots took "
            f"{plain(plan.get('pilot_seconds') or 0.0)} s.")
    paragraphs = [f"<p>{''.join(text)}</p>"]
    if within is False:
        floor, group = floor_db(results)
        floor = plan.get("worst_error_db") if floor is None else floor
        where = f" (group {html.escape(group)})" if group else ""
        paragraphs.append(
            f'<p class="warning"><strong>The budget of {plain(plan["budget_db"])} dB could not be met at the '
            f"data's sampling.</strong> The smallest worst-band error any evaluated setting reaches, the floor, is "
            f"{plain(floor)} dB{where}: the job ran at the cheapest setting near that floor, and the levels of the "
            "bands below carry the errors stated, larger than the budget.</p>")
    if reason is not None:
        paragraphs.append(f"<p>{html.escape(reason)}</p>")
    return "".join(paragraphs)
