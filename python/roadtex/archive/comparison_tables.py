"""The physics tables the job makes for the report besides the runs' own: the seed's model
comparisons on each run's example segment, and the finite model's edge effect at the job's load."""

from __future__ import annotations

import polars as pl

from roadtex.archive.options import ProcessingOptions
from roadtex.archive.schemas import EDGE_EFFECT_SCHEMA, PENETRATION_SCHEMA, VON_MEIER_SCHEMA
from roadtex.comparisons.figures import edge_effect, example_comparisons

#: The tables the job makes from each run's example segment for the report (the seed's figures 2.1, 4.3).
COMPARISON_TABLES = {"von_meier": VON_MEIER_SCHEMA, "penetration": PENETRATION_SCHEMA}


def comparison_tables(example: pl.DataFrame, mean_pressure: float) -> dict[str, pl.DataFrame]:
    """The seed's model comparisons on a run's example segment (``example``, EXAMPLE_SCHEMA: the
    job's own solves at every modulus, at ``mean_pressure`` Pa): its von Meier envelopes and valley
    penetration table (:func:`roadtex.comparisons.figures.example_comparisons`), what the report's
    figures 2.1 and 4.3 draw without computing anything."""
    rows = example.sort("youngs_modulus", "position")
    moduli = rows["youngs_modulus"].unique(maintain_order=True).to_list()
    first = rows.filter(pl.col("youngs_modulus") == moduli[0])
    envelopes = {float(e): rows.filter(pl.col("youngs_modulus") == e)["envelope"].to_numpy() for e in moduli}
    envelope_table, penetration = example_comparisons(first["height"].to_numpy(), float(first["dx"][0]), envelopes,
                                                      mean_pressure=mean_pressure)
    keys = [pl.lit(first["run_id"][0]).alias("run_id"), pl.lit(int(first["segment"][0])).alias("segment")]
    return {name: table.with_columns(keys).select([pl.col(c).cast(t) for c, t in COMPARISON_TABLES[name].items()])
            for name, table in (("von_meier", envelope_table), ("penetration", penetration))}


def edge_effect_table(options: ProcessingOptions, points: int = 1024, length: float = 0.1) -> pl.DataFrame:
    """The seed's figure 3.1 for the job's load and middle modulus: a flat profile of ``length`` (m),
    finite against periodic model (EDGE_EFFECT_SCHEMA), solved here so the report only reads."""
    moduli = sorted(options.youngs_moduli)
    modulus = moduli[len(moduli) // 2]
    table = edge_effect(points=points, length=length, youngs_modulus=modulus, mean_pressure=options.mean_pressure,
                        poisson=options.poisson, tol=1e-10)
    return table.with_columns(pl.lit(modulus).alias("youngs_modulus"),
                              pl.lit(options.mean_pressure).alias("mean_pressure")).cast(EDGE_EFFECT_SCHEMA)  # type: ignore[arg-type]
