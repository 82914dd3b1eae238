"""The seed's comparisons (the INRETS report), in the layer after :mod:`roadtex.spectra`:

- :mod:`roadtex.comparisons.figures`: the data of the seed's figures as tidy tables (von Meier
  envelopes, figure 2.1; the edge effect, 3.1; valleys and penetration, 4.3);
- :mod:`roadtex.comparisons.seed`: the seed's statements checked in one call each
  (:func:`penetration_ranking`, figure 4.3; :func:`depth_effect`, 4.4; :func:`pressure_texture_fits`, 4.6).
"""

from roadtex.comparisons.figures import (
    SEED_D_STAR,
    VALLEY_COLUMNS,
    edge_effect,
    penetration,
    penetration_table,
    valley_penetration,
    valleys,
    von_meier_envelopes,
)
from roadtex.comparisons.seed import SEED_MODULI, SeedCheck, depth_effect, penetration_ranking, pressure_texture_fits

__all__ = ["SEED_D_STAR", "VALLEY_COLUMNS", "edge_effect", "penetration", "penetration_table", "valley_penetration",
           "valleys", "von_meier_envelopes", "SEED_MODULI", "SeedCheck", "depth_effect", "penetration_ranking",
           "pressure_texture_fits"]
