"""Which stretches of road were measured: a segment (or tile) with too few readings has no level.

Drop-outs (and the spikes and gross outliers cleaning removes) are filled before the contact model
and the spectra run, because both need every sample. Filling a few missing readings changes little;
filling a long gap puts a straight line where nobody measured the road, and its "levels" (near
-300 dB: a line has no texture) and its contact (the rubber flat on the line) describe nothing. So
a segment whose readings are missing in more than :data:`MAX_MISSING_SHARE` of its samples is
reported as having no level, with the reason, and counts in no mean; the error budget's pilot never
chooses one.

The limit is the one ISO 13473-1:2019 sets for a valid MPD baseline (at most 10 % of its readings
drop-outs; :func:`roadtex.profiles.mpd.mpd`, ``max_dropout_fraction``), applied to the contact
segments (0.5 m by default) and the surface tiles.

A segment whose readings lie on a straight line (to within rounding: a reference plate flush with the
road, a sensor holding its last reading, a stretch written as a ramp) has no texture either: once
its line is removed what is left is rounding noise, whose "levels" (near -300 dB) would be reported
as measured and, in a pilot's sample, taken for a numerical error of tens of dB
(:func:`flat_segments`). It too has no level, with its reason.
"""

from __future__ import annotations

import numpy as np

#: The largest share of a segment's samples that may be missing for it to have a level (ISO 13473-1:2019's
#: drop-out limit of an MPD baseline).
MAX_MISSING_SHARE = 0.10


def missing_shares(missing: np.ndarray, start_indices: np.ndarray, points: int) -> np.ndarray:
    """The share of missing samples (``missing``: True where the conditioned profile's sample had no
    reading and was filled) in each segment of ``points`` samples starting at ``start_indices``."""
    counts = np.concatenate([[0], np.cumsum(np.asarray(missing, dtype=np.int64))])
    starts = np.asarray(start_indices, dtype=np.int64)
    return (counts[starts + points] - counts[starts]) / float(points)


def too_few_readings(shares: np.ndarray) -> np.ndarray:
    """Whether each segment of missing share ``shares`` has no level (more than :data:`MAX_MISSING_SHARE`)."""
    return np.asarray(shares) > MAX_MISSING_SHARE


#: A segment is flat when the rms of its heights, its line removed, is at most this share of the
#: largest height (m) the profile's arithmetic carried (:func:`flat_segments`). Rounding leaves about
#: 1e-16 of it; a laser profilometer's own resolution (0.1 to 1 um) about 1e-5 on a 10 mm texture. So
#: 1e-9 tells rounding from any measured texture by seven orders of magnitude either way.
FLAT_SHARE = 1e-9


def flat_segments(heights: np.ndarray, scale: float) -> np.ndarray:
    """Whether each segment (rows of ``heights``, m, each with its line removed) is flat to within
    rounding: its rms at most :data:`FLAT_SHARE` times ``scale`` (m), the largest magnitude of the
    profile's heights before the lines were removed (the numbers rounding is relative to)."""
    values = np.asarray(heights, dtype=np.float64)
    rms = np.sqrt(np.mean(values * values, axis=-1))
    return rms <= FLAT_SHARE * abs(float(scale))


def height_scale(heights: np.ndarray) -> float:
    """The largest magnitude (m) of a profile's finite heights (0 for none): :func:`flat_segments`'s scale."""
    values = np.abs(np.asarray(heights, dtype=np.float64))
    finite = values[np.isfinite(values)]
    return float(finite.max()) if finite.size else 0.0


def flat_reason(what: str = "segment") -> str:
    """Why a flat segment (or ``what``) has no level, in words (:func:`flat_segments`)."""
    return (f"no level: the {what}'s readings lie on a straight line (a reference plate, a sensor holding its "
            "last reading): once its line is removed only rounding is left, no texture")


def no_level_reason(share: float, what: str = "segment") -> str:
    """Why a segment (or ``what``) has no level, in words."""
    return (f"no level: {share:.0%} of the {what}'s readings are missing (drop-outs, spikes or outliers removed), "
            f"more than the {MAX_MISSING_SHARE:.0%} ISO 13473-1:2019 allows in an MPD baseline")
