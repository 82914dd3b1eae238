"""The report's account of the error budget (issue 15): the speed-against-error figure of every
setting the job's pilots evaluated, and the table of the numerical error of each band.

A setting is (dx, k, tol): the data at interval dx, solved on a model grid k times finer (every
dx / k, the readings joined by the job's interpolant; issue 34) at solver tolerance tol. Each is
labelled by its model grid ("dx 0.5 mm, k 8 (model 0.0625 mm), tol 10⁻⁸"). Apart from the
numerical error, the band table states what the data's sampling cannot tell: the spread of the
converged contact levels between interpolants of the readings, and which budget bands it makes
sampling-limited (spread above the budget).

Both read only what the job wrote: ``pilot.parquet`` (one row per group, setting and band),
``parameters.json``'s ``plan`` (the job's dx, k and tol, the budget, the error estimate and the
interpolant spread of each band, per group too, the speed-up and the pilots' time) and, for band
labels when the pilot is missing, ``bands.parquet``. A job run with the budget off (empty pilot)
or a results folder from before the budget (no pilot.parquet) or before the model grid (no
``refine``: k = 1, the data's own grid) still gets the figure and the section, saying why there
is nothing to show.
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


def with_model_grid(pilot: pl.DataFrame) -> pl.DataFrame:
    """``pilot.parquet`` with its ``refine`` and ``model_dx`` columns; a pilot from before the model
    grid solved on the data's own grid (k = 1, model dx = dx)."""
    if "refine" in pilot.columns:
        return pilot
    return pilot.with_columns(pl.lit(1, dtype=pl.Int64).alias("refine"), pl.col("dx").alias("model_dx"))


def setting_points(pilot: pl.DataFrame) -> pl.DataFrame:
    """One row per group and setting (dx, refine, tol) of ``pilot.parquet``: ``group``, ``dx`` (m),
    ``refine`` (k), ``tol``, ``choosable``, ``model_dx`` (m), ``points``, ``chosen``, ``reference``,
    ``worst_error_db`` (the largest ``level_error_db`` over the budget bands, dB; inf when one of
    them is not reported at that dx) and ``seconds_per_km`` (measured solve time for every modulus
    per km of road, s/km), in the order the pilot wrote them."""
    # a reference on a grid of its own (``choosable`` False, 0.5.14 on) is no setting: kept apart
    rows = with_model_grid(pilot)
    rows = rows if "choosable" in rows.columns else rows.with_columns(pl.lit(True).alias("choosable"))
    return (rows.group_by("group", "dx", "refine", "tol", "choosable", maintain_order=True)
            .agg(pl.col("model_dx").first(), pl.col("points").first(), pl.col("chosen").any(),
                 pl.col("reference").any(),
                 pl.col("level_error_db").filter(pl.col("in_budget")).max().alias("worst_error_db"),
                 (pl.col("seconds_per_metre").first() * KM).alias("seconds_per_km")))


def setting_label(dx: float, refine: int | None, tol: float | None) -> str:
    """A setting by its model grid: "dx 0.5 mm, k 8 (model 0.0625 mm), tol 10⁻⁸" (dx in m)."""
    k = int(refine or 1)
    return f"dx {plain(dx * MM)} mm, k {k} (model {plain(dx / k * MM)} mm), tol {tolerance(tol)}"


def setting_sentence(dx: float, refine: int | None, tol: float | None) -> str:
    """The same in a sentence: "dx = 0.5 mm, k = 8 (model grid 0.0625 mm), tol = 10⁻⁸" (dx in m)."""
    k = int(refine or 1)
    return f"dx = {plain(dx * MM)} mm, k = {k} (model grid {plain(dx / k * MM)} mm), tol = {tolerance(tol)}"


def line_setting(plan: dict) -> str:
    """The line runs' settings in a sentence: each pilot group's (:func:`setting_sentence`), every run
    on its own readings ("group: dx = 0.5 mm, k = 8 (...), tol = ...; ...")."""
    groups = plan.get("group_errors") or {}
    if not groups:
        return "each run on its own readings (runs.parquet dx_used, refine, tol_used)"
    return "; ".join(f"{html.escape(name)}: {setting_sentence(g['data_dx'], g.get('refine'), g.get('tol'))}"
                     for name, g in groups.items())


def point_label(dx: float, refine: int) -> str:
    """A point of the figure: "0.5" on the data's grid, "0.5×8" refined 8 times (dx in m)."""
    return plain(dx * MM) + (f"×{int(refine)}" if refine != 1 else "")


def pilot_state(results: Results) -> str | None:
    """Why there are no settings to show (a sentence), or None when the pilot has rows."""
    if results.pilot is None:
        return ("No pilot was recorded: this results folder has no pilot.parquet (written by a roadtex "
                "before the error budget), so no candidate setting can be shown.")
    if results.pilot.height == 0:
        budget = (results.parameters.get("options") or {}).get("error_budget_db")
        if budget is not None and results.surface_bands is not None:
            # a budget, but no line run for the job's pilot: the surface runs have their own
            return (f"No line-run pilot: the job's error budget ({plain(budget)} dB) had no line run to study. "
                    "The surface runs carry their own areal pilots' estimates and tolerances (the table of "
                    "the 3D-surfaces section; runs.parquet worst_level_error_db, tol_used).")
        if budget is not None:
            return ("No pilot: the job had an error budget but no pilot could run (parameters.json plan: "
                    "failed_pilots, unread_runs), so no level carries an error estimate.")
        return ("No pilot: the job ran with the error budget off (each run on its own readings: runs.parquet "
                "dx_used, refine, tol_used), so no candidate setting was evaluated and no level carries an error "
                "estimate.")
    return None


def fig_setting_speed_vs_error(plt, results: Results):
    """Per group (device / pavement), every (dx, k, tol) setting the pilot evaluated: time per km
    (s/km) against the worst level error in the budget bands (dB), both logarithmic, one line per
    tol through its (dx, k) candidates from the coarsest model grid to the finest, each point
    labelled "dx×k" (mm); the group's chosen (dx, k, tol) a star, the reference (the data's grid
    refined K times, tol 10⁻¹⁰, at its own estimated error) a square, settings without an error in
    every budget band a triangle at the right edge, the budget a dashed vertical line. Without a
    pilot, one empty pair of axes saying why."""
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
            line = drawn.filter(pl.col("tol") == t).sort("model_dx", "dx")
            if line.height:
                ax.plot(line["worst_error_db"], line["seconds_per_km"], color=colour_of[t], lw=0.8, marker="o",
                        ms=4, label=f"candidate, tol = {tolerance(t)}")
        for row in drawn.iter_rows(named=True):
            text = point_label(row["dx"], row["refine"]) + (" finest (reference)" if row["reference"] else "")
            ax.annotate(text, (row["worst_error_db"], row["seconds_per_km"]), xytext=(4, 3),
                        textcoords="offset points", fontsize=6 if not row["reference"] else 7,
                        color="0.35" if not row["reference"] else "0.1")
        reference = drawn.filter(pl.col("reference"))
        if reference.height:
            ax.scatter(reference["worst_error_db"], reference["seconds_per_km"], s=90, marker="s",
                       facecolors="none", edgecolors="0.25", lw=1.2, zorder=4, label="reference (the readings' road K times finer)")
        unreported = mine.filter(~(pl.col("worst_error_db").is_finite() & (pl.col("worst_error_db") > 0)))
        if unreported.height:
            # settings whose dx does not report every budget band have no finite worst error: drawn at
            # the right edge (their time is measured), so the panel shows every setting evaluated
            edge = ax.get_yaxis_transform()
            ax.scatter([1.0] * unreported.height, unreported["seconds_per_km"], transform=edge, marker=">", s=30,
                       color="0.45", clip_on=False, zorder=4, label="not every budget band reported at its dx")
            for row in unreported.iter_rows(named=True):
                ax.annotate(point_label(row["dx"], row["refine"]), (1.0, row["seconds_per_km"]), xycoords=edge,
                            xytext=(-4, 3), textcoords="offset points", fontsize=6, color="0.35", ha="right")
        chosen = drawn.filter(pl.col("chosen"))
        if chosen.height:
            ax.scatter(chosen["worst_error_db"], chosen["seconds_per_km"], s=160, marker="*", color="#d62728",
                       edgecolors="k", lw=0.6, zorder=5, label="chosen setting", gid="chosen")
        if budget is not None:
            ax.axvline(budget, color="k", ls="--", lw=1.0, label=f"error budget ({plain(budget)} dB)")
        finest = mine.filter(pl.col("reference"))
        if mine.select("dx", "refine").unique().height == 1 and finest.height:
            # one grid tried: say why the panel holds so few points, and what they mean
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
    legend_outside(fig, title="points labelled dx (mm)×k:\nsolved every dx / k")
    return fig


def setting_lines(settings: pl.DataFrame) -> list[str]:
    """["chosen: dx 0.5 mm, k 8 (model 0.0625 mm), tol 10⁻⁸", "reference: dx 0.5 mm, k 32 (model
    0.0156 mm), tol 10⁻¹⁰"] for one group's settings (:func:`setting_points`)."""
    parts = []
    for flag, name in (("chosen", "chosen"), ("reference", "reference")):
        rows = settings.filter(pl.col(flag))
        if rows.height:
            parts.append(f"{name}: {setting_label(rows['dx'][0], rows['refine'][0], rows['tol'][0])}")
    return parts


def plain_log_axes(ax) -> None:
    """Ticks of a log-log axes (and those shared with it) at 1, 2, 5 x 10^k, written plainly (0.2, 5, 100)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(FuncFormatter(lambda value, _: plain(value)))
        axis.set_minor_formatter(NullFormatter())


def by_band(mapping: dict[str, float] | None) -> dict[int, float]:
    """A JSON band -> value mapping of parameters.json with the band numbers as ints."""
    return {int(b): float(v) for b, v in (mapping or {}).items() if v is not None}


def spread_per_band(results: Results) -> dict[int, float]:
    """Band number -> what the sampling cannot tell (dB): parameters.json's plan
    ``interpolant_spread_db`` (the largest of any group), else the largest of bands.parquet's
    ``interpolant_spread_db`` per band; empty when the job did not measure it."""
    spread = by_band(results.plan.get("interpolant_spread_db"))
    if spread or "interpolant_spread_db" not in results.bands.columns:
        return spread
    measured = (results.bands.filter(pl.col("interpolant_spread_db").is_not_null())
                .group_by("band").agg(pl.col("interpolant_spread_db").max()))
    return dict(measured.iter_rows())


def error_rows(results: Results) -> pl.DataFrame:
    """The plan's bands: ``band``, ``label``, ``centre_wavelength`` (m), ``in_budget``,
    ``plan_error_db`` (parameters.json's estimate at the job's setting, dB) and ``spread_db`` (what
    the sampling cannot tell, :func:`spread_per_band`, dB; null where not measured), from
    pilot.parquet's band facts (bands.parquet's when there is no pilot)."""
    estimates = by_band(results.plan.get("band_error_db"))
    spread = spread_per_band(results)
    table = pl.DataFrame({"band": list(estimates), "plan_error_db": list(estimates.values()),
                          "spread_db": [spread.get(b) for b in estimates]},
                         schema={"band": pl.Int64, "plan_error_db": pl.Float64, "spread_db": pl.Float64})
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


#: The band table's columns of what the sampling cannot tell.
SPREAD_COLUMN = "interpolant spread (dB): what the sampling cannot tell"
LIMITED_COLUMN = "sampling-limited (spread above the budget)"


def band_error_table(results: Results) -> pl.DataFrame:
    """The table "numerical error per band": per band of the plan, its label and centre wavelength
    (mm), whether the budget applies to it, the plan's estimated error at the job's setting (dB),
    what the data's sampling cannot tell (the interpolant spread of the converged contact levels,
    dB, the largest of any group) and whether that makes the band sampling-limited (spread above
    the budget), when the job measured it, and, per pilot group, the estimated error at that
    group's chosen setting (dB). Empty without a plan estimate (budget off)."""
    rows = error_rows(results)
    budget = results.plan.get("budget_db")
    columns = [pl.col("label").alias("band (mm)"), (pl.col("centre_wavelength") * MM).alias("centre wavelength (mm)"),
               pl.col("in_budget").alias("in budget"),
               pl.col("plan_error_db").map_elements(error_text, return_dtype=pl.String)
               .alias("estimated error at the job's setting (dB)")]
    if rows["spread_db"].is_not_null().any() and budget is not None:
        columns += [pl.col("spread_db").alias(SPREAD_COLUMN), (pl.col("spread_db") > budget).alias(LIMITED_COLUMN)]
    table = rows.select(columns)
    if results.pilot is None or results.pilot.height == 0:
        return table
    chosen = results.pilot.filter(pl.col("chosen")).group_by("group", "band", maintain_order=True).agg(
        pl.col("level_error_db").max())
    for group in results.pilot["group"].unique(maintain_order=True).to_list():
        errors = dict(chosen.filter(pl.col("group") == group).select("band", "level_error_db").iter_rows())
        table = table.with_columns(pl.Series(f"at the chosen setting of {group} (dB)",
                                             [error_text(errors.get(b)) for b in rows["band"]], dtype=pl.String))
    return table


def limited_bands(results: Results) -> dict[str, list[str]]:
    """Per pilot group (parameters.json plan ``group_errors``; the whole plan as "all groups" when
    it has none), the labels of the budget bands whose interpolant spread exceeds the budget,
    longest wavelength first; the bands of every band of the plan when the budget bands are not
    known (no pilot)."""
    plan = results.plan
    budget = plan.get("budget_db")
    rows = error_rows(results)
    known = rows["in_budget"].is_not_null().any()
    wanted = rows.filter(pl.col("in_budget")) if known else rows
    labels = dict(wanted.select("band", "label").iter_rows())
    groups = {name: by_band(group.get("interpolant_spread_db"))
              for name, group in (plan.get("group_errors") or {}).items()}
    groups = {name: spread for name, spread in groups.items() if spread} or {"all groups": spread_per_band(results)}
    return {name: [labels[b] for b in sorted(labels) if spread.get(b, float("nan")) > budget]
            for name, spread in groups.items()}


def sampling_summary(results: Results) -> str:
    """The paragraph (HTML) on what the data's sampling cannot tell, apart from the numerical error,
    and which budget bands it makes sampling-limited, per group; empty when the job did not measure
    it (budget off, or a job from before the model grid)."""
    budget = results.plan.get("budget_db")
    if budget is None or not spread_per_band(results):
        return ""
    rows = error_rows(results)
    known = rows["in_budget"].is_not_null().any()
    count = int(rows["in_budget"].sum()) if known else rows.height
    which = "budget bands" if known else "bands"
    limited = limited_bands(results)
    said = "; ".join(f"{html.escape(name)}: " + (f"{', '.join(labels)} mm ({len(labels)} of {count})" if labels
                                                  else "none")
                     for name, labels in limited.items())
    return (
        "<p>What the data's sampling cannot tell, stated apart from the numerical error: the spread of the "
        "converged contact levels (enveloped texture, pressure) between interpolants of the readings (linear, "
        "monotone cubic, band-limited), column “interpolant spread” (the largest of any group; bands.parquet "
        "interpolant_spread_db per run, its group's). Where it exceeds the budget of "
        f"{plain(budget)} dB the band is sampling-limited (bands.parquet sampling_limited): the data's "
        "resolution, not the solver, bounds its contact levels, and no finer model grid removes that. "
        f"Sampling-limited {which}: {said}.</p>")


def choosable(points: pl.DataFrame, results: Results) -> pl.DataFrame:
    """The settings of :func:`setting_points` the pilots could choose from (a reference on a grid of
    its own is none): those matching what the caller forced (parameters.json ``options`` dx,
    refine, tol; for dx the group's nearest interval, as the pilot takes it); all of them when
    nothing was forced."""
    requested = results.parameters.get("options") or {}
    chosen = points.filter(pl.col("choosable"))
    if requested.get("dx") is not None:
        gap = (pl.col("dx") - requested["dx"]).abs()
        chosen = chosen.filter(gap == gap.min().over("group"))
    if requested.get("refine") is not None:
        chosen = chosen.filter(pl.col("refine") == int(requested["refine"]))
    if requested.get("tol") is not None:
        chosen = chosen.filter((pl.col("tol") / requested["tol"] - 1.0).abs() < 1e-9)
    return chosen if chosen.height else points


def floor_db(results: Results) -> tuple[float | None, str | None]:
    """The smallest worst-band error any setting the pilot could choose (:func:`choosable`)
    reaches, for the group where that is largest (the budget the job's settings allow), and that
    group; (None, None) without a pilot."""
    if results.pilot is None or results.pilot.height == 0:
        return None, None
    best = choosable(setting_points(results.pilot), results).group_by("group").agg(
        pl.col("worst_error_db").min()).sort("worst_error_db", descending=True)
    return float(best["worst_error_db"][0]), str(best["group"][0])


#: How the job's interpolants join the readings, in words.
INTERPOLANT_WORDS = {"linear": "joined linearly", "pchip": "joined by monotone cubics",
                     "bandlimited": "joined band-limited"}


def job_verdict(results: Results) -> tuple[bool | None, float]:
    """Whether every run is within the budget, and the worst estimated error (dB) of any run: from
    runs.parquet's ``within_budget`` and ``worst_level_error_db``, line and surface runs alike (the
    plan's verdict is its line pilots' only); the plan's where the table has none."""
    plan = results.plan
    runs = results.runs
    if "within_budget" in runs.columns and runs["within_budget"].drop_nulls().len():
        worst = runs["worst_level_error_db"].drop_nulls().drop_nans() if "worst_level_error_db" in runs.columns else None
        return (bool(runs["within_budget"].drop_nulls().all()),
                float(worst.max()) if worst is not None and worst.len() else float("nan"))
    return plan.get("within_budget"), float(plan.get("worst_error_db") or float("nan"))


def budget_summary(results: Results) -> str:
    """The section's paragraphs (HTML): budget, the setting used (dx, k and its model grid, tol),
    the verdict, the speed-up against the reference and the pilots' measured time; what the
    budget could not reach, plainly."""
    plan = results.plan
    reason = pilot_state(results)
    if plan.get("budget_db") is None:
        return f"<p>{html.escape(reason or 'No error budget on record.')}</p>"
    shortest, longest = noise_wavelength_range()
    (f_low, f_high), (v_low, v_high) = NOISE_FREQUENCY_RANGE, NOISE_SPEED_RANGE_KMH
    within, worst = job_verdict(results)
    surfaces = ("; surface runs on their own model grid (k times finer than their spacings each way) and the "
                "tolerance their own pilot chose (runs.parquet refine, refine_across, model_dx, model_dy, "
                "tol_used)" if results.surface_bands is not None else "")
    joined = INTERPOLANT_WORDS.get(str(results.options.get("interpolant", "linear")), "joined")
    text = [
        f"Error budget {plain(plan['budget_db'])} dB on every level (texture, enveloped texture, contact pressure) "
        f"in the tyre/road noise bands (those marked “in budget” below: reported, and overlapping {plain(f_low)} Hz to "
        f"{plain(f_high / 1e3)} kHz at {plain(v_low)} to {plain(v_high)} km/h, wavelengths {plain(shortest * MM)} "
        f"to {plain(longest * MM)} mm). "
        f"Every line run was solved on its own readings, as its pilot group chose ({line_setting(plan)}; a run of "
        "a sampling no pilot measured on the finest model grid of any group, runs.parquet error_source): the contact "
        f"model on a grid k times finer than the data's, the readings {joined}, texture levels the data's "
        f"({html.escape(str(plan.get('source', '')))}){surfaces}. "
        f"Within budget: {'yes' if within else 'no'}; worst estimated error in the budget bands "
        f"{plain(worst)} dB (every run, line and surface: runs.parquet within_budget, worst_level_error_db)."]
    if plan.get("speedup") is not None:
        reference = "the file's sampling on the finest model grid, tightest tolerance"
        if results.pilot is not None and results.pilot.height:
            rows = with_model_grid(results.pilot).filter(pl.col("reference"))
            ks, tols = sorted(set(rows["refine"].to_list())), sorted(set(rows["tol"].to_list()))
            if ks:
                reference = (f"the readings' road k = {', '.join(map(str, ks))} times finer than the file's sampling, "
                             f"tol {', '.join(tolerance(t) for t in tols)}")
        text.append(
            f" Speed-up against the reference (each group's converged answer: {reference}): "
            f"{plain(plan['speedup'])} times less solver work (iterations × N log₂ N per metre, counted by the "
            f"pilots, so the same data always gives the same choice). Measured by the pilots: "
            f"{plain((plan.get('seconds_per_metre') or float('nan')) * KM)} s per km at the chosen setting against "
            f"{plain((plan.get('finest_seconds_per_metre') or float('nan')) * KM)} s per km at the reference "
            f"(every modulus; the machine's load moves these); the pilots took "
            f"{plain(plan.get('pilot_seconds') or 0.0)} s.")
    paragraphs = [f"<p>{''.join(text)}</p>"]
    if within is False:
        floor, group = floor_db(results)
        floor = (plan.get("worst_error_db") or worst) if floor is None else floor
        where = f" (group {html.escape(group)})" if group else ""
        paragraphs.append(
            f'<p class="warning"><strong>The budget of {plain(plan["budget_db"])} dB could not be met by any '
            f"setting the pilots could choose.</strong> The smallest worst-band error those settings reach (the "
            f"ones the options allow: a forced dx, k or tol restricts them), the floor, is {plain(floor)} dB{where}: "
            "the job ran at the cheapest setting near that floor, and the levels of the bands below carry the "
            "errors stated, larger than the budget.</p>")
    if reason is not None:
        paragraphs.append(f"<p>{html.escape(reason)}</p>")
    return "".join(paragraphs)
