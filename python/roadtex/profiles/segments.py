"""Equal-length segments of a uniform profile for the periodic contact model, and stitching
per-segment results back into one profile."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from roadtex import _core
from roadtex._checks import finite_number, positive, whole_number
from roadtex.errors import InvalidInputError
from roadtex.profiles.conditioning import require_grid
from roadtex.profiles.trend import remove_end_lines, remove_lines

if TYPE_CHECKING:
    from roadtex.profiles.profile import Profile

#: How a segment is detrended: ``"ends"`` (the default) the line through its first and last sample,
#: so the periodic extension has no step at the wrap; ``"least_squares"`` its least-squares line.
SegmentDetrend = Literal["ends", "least_squares"]


@dataclass(frozen=True)
class Segments:
    """Equal-length segments of a uniform profile, for :func:`roadtex.contact_many`.

    Attributes:
        heights: (n_segments, points_per_segment) heights (m), NaN-free, each segment's line
            removed unless ``detrend=False`` was asked: by default the line through its first and
            last sample, plus its mean, so that its ends meet (see :meth:`Profile.segments`).
        starts: (n_segments,) position of each segment's first sample (m).
        dx, length, overlap: sampling (m), segment length (m, points * dx), nominal overlap (m).
        trends: (n_segments, points_per_segment) the line removed from each segment (m; zeros
            when not detrended): ``heights + trends`` are the profile's own heights.
        detrend: how the segments were detrended: ``"ends"``, ``"least_squares"`` or ``None``.
        start_indices: index of each segment's first sample in the profile.
        profile_positions: positions of the whole profile (m).
    """

    heights: np.ndarray
    starts: np.ndarray
    dx: float
    length: float
    overlap: float
    trends: np.ndarray
    start_indices: np.ndarray
    profile_positions: np.ndarray
    detrend: SegmentDetrend | None = "ends"

    def __len__(self) -> int:
        return int(self.heights.shape[0])

    @property
    def points_per_segment(self) -> int:
        return int(self.heights.shape[1])

    def stitch(self, values: np.ndarray, *, method: Literal["crossfade", "centre"] = "crossfade",
               add_trend: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """One seamless profile from per-segment results.

        Args:
            values: (n_segments, points_per_segment) results, e.g. envelopes (m) or pressures (Pa)
                from :func:`roadtex.contact_many` for one modulus.
            method: where segments overlap, ``"crossfade"`` weights each segment by its distance
                from its own nearest end (a linear ramp across the overlap), so the result is
                continuous and values near a segment's ends (where the periodic model sees its
                seam) count least; ``"centre"`` takes each sample from the segment whose centre is
                nearest, discarding segment ends entirely (can leave a small step where it switches).
                Without overlap both simply concatenate.
            add_trend: add back each segment's removed line, for heights or envelopes in the
                profile's frame (not for pressures).

        Returns:
            (positions (m), values) covering the whole profile.
        """
        array = np.asarray(values, dtype=np.float64)
        if array.shape != self.heights.shape:
            raise InvalidInputError(f"values must have shape {self.heights.shape} (segments, points), got {array.shape}")
        if method not in ("crossfade", "centre"):
            raise InvalidInputError(f"method must be 'crossfade' or 'centre', got {method!r}")
        if add_trend:
            array = array + self.trends
        n_seg, points = array.shape
        n = self.profile_positions.size
        index = self.start_indices[:, None] + np.arange(points)[None, :]
        # distance of each sample from its segment's nearest end, in samples (0.5 at the end sample)
        edge = np.minimum(np.arange(points), np.arange(points)[::-1]) + 0.5
        if method == "crossfade":
            ramp = max(self.overlap / self.dx, 1.0)
            weight = np.broadcast_to(np.minimum(edge / ramp, 1.0), array.shape)
        else:
            centre = self.start_indices + 0.5 * (points - 1)
            # each sample belongs to the segment whose centre is nearest: boundaries at midpoints
            bounds = np.concatenate([[-np.inf], 0.5 * (centre[1:] + centre[:-1]), [np.inf]])
            weight = ((index >= bounds[:-1, None]) & (index < bounds[1:, None])).astype(np.float64)
        total = np.bincount(index.ravel(), weights=(weight * array).ravel(), minlength=n)
        norm = np.bincount(index.ravel(), weights=weight.ravel(), minlength=n)
        return self.profile_positions.copy(), total / norm


# --------------------------------------------------------------------------------------------------


def fft_friendly_length(n: int) -> int:
    """The smallest FFT-friendly point count at or above ``n``: 5-smooth, 2^a 3^b 5^c (points).

    The contact solve transforms every segment many times, and realfft is fastest on such sizes:
    13,334 points (a 0.5 m segment at 0.0375 mm; 2 x 59 x 113) cost some 17 times more per point than
    2^16. Where segments are resampled anyway, resample to ``fft_friendly_length(n)`` points
    (13,500 here). Returns 1 for n = 0 or 1; ``n`` must be a whole number >= 0 and at most 2^40.
    """
    return _core.fft_friendly_length(whole_number(n, "n", 0))


def segment_detrend(detrend: object) -> SegmentDetrend | None:
    """The detrend a ``detrend`` argument of :meth:`Profile.segments` names: True (the default
    detrend) and ``"ends"`` give ``"ends"``, ``"least_squares"`` itself, False or None give None."""
    if detrend is True:
        return "ends"
    if detrend is False or detrend is None:
        return None
    if detrend in ("ends", "least_squares"):
        return detrend  # type: ignore[return-value]
    raise InvalidInputError(f"detrend must be 'ends', 'least_squares', True or False, got {detrend!r}")


def cut_segments(profile: Profile, length: float, overlap: float = 0.0, *,
                 detrend: SegmentDetrend | bool = "ends") -> Segments:
    """Equal segments of ``length`` (m) overlapping by ``overlap`` (m); see :meth:`Profile.segments`."""
    kind = segment_detrend(detrend)
    require_grid(profile, "segments")
    length_f = positive(length, "length")
    overlap_f = finite_number(overlap, "overlap")
    points = int(round(length_f / profile.dx))
    overlap_points = int(round(overlap_f / profile.dx))
    if points < 2:
        raise InvalidInputError(f"segment length {length_f:.3g} m is less than 2 samples of dx {profile.dx:.3g} m")
    if not 0 <= overlap_points < points:
        raise InvalidInputError(f"overlap must be in [0, length), got {overlap_f!r} m for length {length_f!r} m")
    n = profile.heights.size
    if points > n:
        raise InvalidInputError(f"segment length {length_f:.6g} m exceeds the profile ({profile.length:.6g} m)")
    step = points - overlap_points
    starts = list(range(0, n - points + 1, step))
    if starts[-1] + points < n:
        starts.append(n - points)
    start_index = np.asarray(starts, dtype=np.int64)
    take = start_index[:, None] + np.arange(points)[None, :]
    heights = profile.heights[take]
    trends = np.zeros_like(heights)
    if kind == "ends":
        heights, trends = remove_end_lines(heights, profile.dx * np.arange(points))
    elif kind == "least_squares":
        heights, trends = remove_lines(heights, profile.dx * np.arange(points))
    return Segments(heights=heights, starts=profile.positions[start_index], dx=profile.dx,
                    length=points * profile.dx, overlap=overlap_points * profile.dx, trends=trends,
                    start_indices=start_index, profile_positions=profile.positions, detrend=kind)
