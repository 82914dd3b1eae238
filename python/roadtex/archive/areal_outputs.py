"""areal.parquet: the ISO 25178-2 areal parameters of each surface run, whole and per tile
(:func:`roadtex.surfaces.areal.areal_parameters`, its filter settings in the ``filters`` column)."""

from __future__ import annotations

import polars as pl

from roadtex.archive.schemas import AREAL_SCHEMA
from roadtex.surfaces.areal import AREAL_FILTERS, AREAL_PARAMETERS, areal_parameters
from roadtex.surfaces.surface import Surface
from roadtex.surfaces.tiles import Tiles


def areal_table(run_id: str, surface: Surface, tiles: Tiles) -> pl.DataFrame:
    """One row for the conditioned surface of the run (``scope`` "run") and one per tile (``scope``
    "tile", as the contact model solved it), with where it lies (m) and its parameters."""
    rows = [{"run_id": run_id, "scope": "run", "tile": None, "start": surface.x0,
             "end": surface.x0 + surface.dx * surface.shape[1], "width": surface.dy * surface.shape[0],
             **areal_parameters(surface)}]
    for index, (x, _) in enumerate(tiles.starts):
        rows.append({"run_id": run_id, "scope": "tile", "tile": index, "start": float(x), "end": float(x) + tiles.length,
                     "width": tiles.width, **areal_parameters(tiles.heights[index], tiles.dx, tiles.dy)})
    return pl.DataFrame(rows, schema={k: v for k, v in AREAL_SCHEMA.items() if k != "filters"}).with_columns(
        pl.lit(AREAL_FILTERS).alias("filters")).select(list(AREAL_SCHEMA)).with_columns(
        pl.col(name).fill_nan(None) for name in AREAL_PARAMETERS)
