"""Road profiles: the :class:`Profile` model, its conditioning, segments for the contact model,
readers and writers (CAPTIF, CSV/TSV, npy, Parquet), mean profile depth (ISO 13473-1) and
synthetic profiles. Units: metres."""

from roadtex.profiles.mpd import MpdResult, mpd
from roadtex.profiles.pavements import synthetic_pavement
from roadtex.profiles.profile import Profile
from roadtex.profiles.readers import read_profile
from roadtex.profiles.segments import Segments
from roadtex.profiles.synthetic import self_affine_profile
from roadtex.profiles.writer import write_profile

__all__ = ["MpdResult", "Profile", "Segments", "mpd", "read_profile", "self_affine_profile", "synthetic_pavement",
           "write_profile"]
