"""Road surfaces (3D texture): the :class:`Surface` model (``heights[iy, ix]`` in metres, rows
across the road, columns along it), its conditioning, longitudinal lines as profiles, tiles for
the areal contact model, readers (2-D npy, long tables in Parquet or CSV, OpenCRG) and synthetic
3D pavements, ISO 25178-2 areal parameters. Units: metres."""

from roadtex.surfaces.areal import areal_parameters
from roadtex.surfaces.readers import read_surface
from roadtex.surfaces.surface import Surface
from roadtex.surfaces.synthetic import sett_surface, synthetic_surface
from roadtex.surfaces.tiles import Tiles

__all__ = ["Surface", "Tiles", "areal_parameters", "read_surface", "sett_surface", "synthetic_surface"]
