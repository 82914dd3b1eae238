"""Measured road profiles: reading, ISO 13473-1 style conditioning, and segments for the contact model.

A :class:`Profile` holds heights and positions in metres, with NaN marking drop-outs (readings the
laser did not get). Every conditioning step returns a new profile and appends a line to its
``history``, so a result says how it was obtained.

Readers (:func:`read_profile`) understand the CAPTIF stationary laser profilometer text format,
CSV/TSV text with a distance and a height column, ``.npy`` arrays and Parquet tables, and convert
everything to metres. :func:`write_profile` writes CSV, ``.npy`` or Parquet files that read back to
the same heights, positions, metadata and history.
"""

from __future__ import annotations

import io
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Literal

import numpy as np
import polars as pl

from roadtex._checks import finite_number, positive

# Above this magnitude (m) a height or position is a wrong unit or a corrupt file, not a road, and
# sums of squares over millions of samples would start to lose meaning.
_MAX_MAGNITUDE = 1e9

_UNITS = {
    "m": 1.0, "metre": 1.0, "metres": 1.0, "meter": 1.0, "meters": 1.0,
    "mm": 1e-3, "millimetre": 1e-3, "millimetres": 1e-3, "millimeter": 1e-3, "millimeters": 1e-3,
    "cm": 1e-2, "km": 1e3,
    "um": 1e-6, "µm": 1e-6, "μm": 1e-6, "micron": 1e-6, "microns": 1e-6, "micrometre": 1e-6,
    "micrometer": 1e-6, "in": 0.0254, "inch": 0.0254, "inches": 0.0254, "ft": 0.3048,
}
_DISTANCE_NAMES = ("distance", "dist", "position", "pos", "x", "chainage", "station", "s",
                   "longitudinal_position", "location")
_HEIGHT_NAMES = ("height", "z", "elevation", "profile", "texture", "h", "y", "relative_height")
_FORMATS = ("captif", "csv", "npy", "parquet")
_CAPTIF_MARKER = b"*****DATA*****"
_ROADTEX_TAG = "roadtex-profile"


# --------------------------------------------------------------------------------------------------
# array checks of this module (scalar checks: roadtex._checks)


def _as_1d(values: object, name: str) -> np.ndarray:
    try:
        array = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric: {exc}") from None
    if array.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array, got an array of shape {array.shape}")
    return array


def _frozen(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


def _fmt(value: float) -> str:
    return f"{value:.6g}"


# --------------------------------------------------------------------------------------------------
# zero-phase Butterworth filters (ISO 13473-1 Annex D uses 2nd-order Butterworth sections)

def _butterworth2(dx: float, cutoff_wavelength: float, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """b, a of a 2nd-order digital Butterworth filter (bilinear transform with pre-warping)."""
    k = math.tan(math.pi * dx / cutoff_wavelength)
    norm = 1.0 + math.sqrt(2.0) * k + k * k
    a = np.array([1.0, 2.0 * (k * k - 1.0) / norm, (1.0 - math.sqrt(2.0) * k + k * k) / norm])
    if kind == "low":
        b = np.array([k * k, 2.0 * k * k, k * k]) / norm
    else:
        b = np.array([1.0, -2.0, 1.0]) / norm
    return b, a


def _impulse_response(b: np.ndarray, a: np.ndarray, n_max: int) -> np.ndarray:
    # The poles are a complex pair of radius sqrt(a2) (or real, radius below 1); stop where the
    # response has decayed below double precision relative to its start.
    radius = max(abs(r) for r in np.roots(a))
    length = n_max if radius <= 0.0 else int(min(n_max, math.ceil(math.log(1e-18) / math.log(radius)) + 8))
    length = max(length, 3)
    h = np.zeros(length)
    x = np.zeros(length)
    x[0] = 1.0
    for i in range(length):
        acc = b[0] * x[i]
        if i >= 1:
            acc += b[1] * x[i - 1] - a[1] * h[i - 1]
        if i >= 2:
            acc += b[2] * x[i - 2] - a[2] * h[i - 2]
        h[i] = acc
    return h


def _convolve_valid_tail(signal: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Causal filtering of ``signal`` by ``kernel`` as if ``signal[0]`` had held forever before."""
    m = kernel.size
    padded = np.concatenate([np.full(m, signal[0]), signal])
    if m <= 128:
        full = np.convolve(padded, kernel)
    else:
        size = 1 << int(math.ceil(math.log2(padded.size + m - 1)))
        full = np.fft.irfft(np.fft.rfft(padded, size) * np.fft.rfft(kernel, size), size)
    return full[m:m + signal.size]


def _filtfilt(heights: np.ndarray, dx: float, cutoff_wavelength: float, kind: str) -> np.ndarray:
    """Forward-backward 2nd-order Butterworth filter (zero phase, gain 1/2 at the cut-off).

    Ends are handled as scipy.signal.sosfiltfilt does by default: an odd extension of 9 samples and
    steady-state initial conditions, so the result matches that reference implementation.
    """
    b, a = _butterworth2(dx, cutoff_wavelength, kind)
    n = heights.size
    pad = min(9, n - 1)
    ext = np.concatenate([2 * heights[0] - heights[pad:0:-1], heights,
                          2 * heights[-1] - heights[-2:-pad - 2:-1]])
    h = _impulse_response(b, a, n_max=4 * ext.size)
    forward = _convolve_valid_tail(ext, h)
    backward = _convolve_valid_tail(forward[::-1], h)[::-1]
    return backward[pad:pad + n]


# --------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Profile:
    """A measured (or synthetic) line profile of a road surface.

    Attributes:
        heights: surface heights (m), positive up, float64; NaN marks a drop-out.
        positions: longitudinal positions of the samples (m), strictly increasing.
        dx: the nominal sampling interval (m): exact for uniform profiles (after :meth:`resample`),
            the mean spacing for a raw file. Each sample is taken to represent a length dx.
        metadata: what the source says about the measurement (site, wheel_path, date, device,
            direction, source file, ...). Values are plain JSON types so files round-trip them.
        history: one human-readable line per step that produced this profile, with its parameters.

    Arrays are read-only; every method returns a new :class:`Profile`.
    """

    heights: np.ndarray
    positions: np.ndarray
    dx: float
    metadata: dict[str, object] = field(default_factory=dict)
    history: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        heights = _as_1d(self.heights, "heights")
        positions = _as_1d(self.positions, "positions")
        if heights.size != positions.size:
            raise ValueError(f"heights and positions must have the same length, got {heights.size} and {positions.size}")
        if heights.size < 2:
            raise ValueError(f"a profile needs at least 2 samples, got {heights.size}")
        if not np.all(np.isfinite(positions)):
            raise ValueError("positions must be finite (no NaN or inf)")
        if np.isinf(heights).any():
            raise ValueError(f"heights contain inf at sample {int(np.flatnonzero(np.isinf(heights))[0])} "
                             "(overflow in the source?); drop-outs must be NaN")
        if np.isnan(heights).all():
            raise ValueError("all heights are NaN (drop-outs): no valid reading in the profile")
        biggest = max(float(np.nanmax(np.abs(heights))), float(np.max(np.abs(positions))))
        if biggest > _MAX_MAGNITUDE:
            raise ValueError(f"a height or position of {biggest:.3g} m is beyond {_MAX_MAGNITUDE:.0g} m: "
                             "not a road profile (wrong unit or a corrupt file?)")
        steps = np.diff(positions)
        if not np.all(steps > 0):
            bad = int(np.flatnonzero(steps <= 0)[0])
            kind = "duplicate" if steps[bad] == 0 else "decreasing"
            raise ValueError(f"positions must be strictly increasing: {kind} position at sample {bad + 1} "
                             f"({positions[bad]:.9g} m then {positions[bad + 1]:.9g} m)")
        dx = positive(self.dx, "dx")
        object.__setattr__(self, "heights", _frozen(heights))
        object.__setattr__(self, "positions", _frozen(positions))
        object.__setattr__(self, "dx", dx)
        object.__setattr__(self, "metadata", dict(self.metadata))
        object.__setattr__(self, "history", tuple(str(h) for h in self.history))

    # ---------------------------------------------------------------------------------------------
    @classmethod
    def from_heights(cls, heights: Iterable[float] | np.ndarray, dx: float, *, start: float = 0.0,
                     metadata: dict[str, object] | None = None, history: Iterable[str] = ()) -> "Profile":
        """A uniform profile from heights (m) on a grid of spacing ``dx`` (m) starting at ``start`` (m)."""
        z = _as_1d(heights, "heights")
        dx_f = positive(dx, "dx")
        x = finite_number(start, "start") + dx_f * np.arange(z.size)
        return cls(z, x, dx_f, dict(metadata or {}), tuple(history))

    def _with(self, heights: np.ndarray, positions: np.ndarray | None = None, dx: float | None = None,
              step: str = "") -> "Profile":
        """A new profile from a step of this one. The steps keep the invariants (positions
        increasing and finite, no inf, some valid height), so the checks of __init__, a good part
        of the cost on millions of samples, are skipped."""
        new = object.__new__(Profile)
        new_positions = self.positions if positions is None else positions
        for name, value in (("heights", _frozen(np.ascontiguousarray(heights, dtype=np.float64))),
                            ("positions", _frozen(np.ascontiguousarray(new_positions, dtype=np.float64))),
                            ("dx", float(self.dx if dx is None else dx)), ("metadata", dict(self.metadata)),
                            ("history", self.history + ((step,) if step else ()))):
            object.__setattr__(new, name, value)
        return new

    @property
    def length(self) -> float:
        """Length covered (m): span of the positions plus one dx (n dx for a uniform profile)."""
        return float(self.positions[-1] - self.positions[0] + self.dx)

    @property
    def dropout_fraction(self) -> float:
        """Share of samples that are drop-outs (NaN), 0..1."""
        return float(np.count_nonzero(np.isnan(self.heights)) / self.heights.size)

    @property
    def is_uniform(self) -> bool:
        """True when every spacing equals dx to 1e-6 dx (a grid, as after :meth:`resample`)."""
        return bool(np.max(np.abs(np.diff(self.positions) - self.dx)) <= 1e-6 * self.dx)

    def __len__(self) -> int:
        return int(self.heights.size)

    # ---------------------------------------------------------------------------------------------
    def trim_reference_plates(self, *, threshold: float = 0.02, margin: float = 0.002) -> "Profile":
        """Cuts away reference plates at the ends of the profile and everything outside them.

        Stationary profilometers such as CAPTIF's show calibration plates far above the road at both
        ends; the road section of interest lies between them. A plate is any reading more than
        ``threshold`` (m) above the median height; drop-outs inside a plate (the laser often loses
        the plate's top) belong to it. On each half of the profile the plate nearest the centre is
        found, and the profile keeps what lies between the last road reading before (after) the
        plate, moved inwards by ``margin`` (m) to drop the plate's edge. A half without a plate is
        left as it is; the step is still recorded.

        Raises:
            ValueError: nothing would be left between the plates.
        """
        threshold_f = positive(threshold, "threshold")
        margin_f = finite_number(margin, "margin")
        if margin_f < 0:
            raise ValueError(f"margin must be >= 0 (m), got {margin!r}")
        z, x = self.heights, self.positions
        # the median only sets a reference level 20 mm below plates: every 7th reading is plenty
        plate = z > np.nanmedian(z[::7]) + threshold_f        # NaN compares False
        middle = int(np.searchsorted(x, 0.5 * (x[0] + x[-1])))
        lo, hi = x[0], x[-1]
        found = []
        first_half = np.flatnonzero(plate[:middle])
        if first_half.size:
            tail = z[first_half[-1]:]
            after = np.flatnonzero(~np.isnan(tail) & ~plate[first_half[-1]:])
            if after.size:
                lo = x[first_half[-1] + after[0]] + margin_f
                found.append("start")
        second_half = np.flatnonzero(plate[middle:]) + middle
        if second_half.size:
            before = np.flatnonzero(~np.isnan(z[:second_half[0]]) & ~plate[:second_half[0]])
            if before.size:
                hi = x[before[-1]] - margin_f
                found.append("end")
        # what is kept is one run of samples: slice it rather than copy it
        first, stop = int(np.searchsorted(x, lo, "left")), int(np.searchsorted(x, hi, "right"))
        if stop - first < 2 or np.isnan(z[first:stop]).all():
            raise ValueError(f"trimming reference plates leaves no road between {lo:.6g} m and {hi:.6g} m")
        keep = slice(first, stop)
        where = " and ".join(found) if found else "none found"
        step = (f"trim_reference_plates(threshold={_fmt(threshold_f)} m, margin={_fmt(margin_f)} m): "
                f"plates at {where}; kept {_fmt(float(x[first]))}..{_fmt(float(x[stop - 1]))} m")
        return self._with(z[keep], x[keep], step=step)

    def remove_spikes(self, alpha: float = 3.0) -> "Profile":
        """Flags spikes as drop-outs (NaN), with the ISO 13473-1:2019 (Annex E) criterion.

        A jump between consecutive valid readings i-1, i is a spike when
        |z_i - z_(i-1)| >= alpha * (x_i - x_(i-1)): a slope steeper than ``alpha`` (3 in the
        standard, about 72 degrees). Both readings of the jump are flagged, as in the standard and
        in captif-slp. The criterion is meant for profiles resampled to 0.5 or 1 mm; on finer raw
        sampling it also flags steep but real stone edges. Alpha = 6 suits coarse chip seals
        measured by the CAPTIF laser (its authors' setting).
        """
        alpha_f = positive(alpha, "alpha", "a slope, no unit")
        z = self.heights.copy()
        valid_index = np.flatnonzero(~np.isnan(z))
        jump = np.abs(np.diff(z[valid_index])) >= alpha_f * np.diff(self.positions[valid_index])
        flagged = np.zeros(valid_index.size, dtype=bool)
        flagged[:-1] |= jump
        flagged[1:] |= jump
        z[valid_index[flagged]] = np.nan
        step = f"remove_spikes(alpha={_fmt(alpha_f)}): {int(flagged.sum())} readings flagged as drop-outs"
        return self._with(z, step=step)

    def fill_dropouts(self) -> "Profile":
        """Replaces drop-outs (NaN) by linear interpolation between the nearest valid readings.

        Leading and trailing drop-outs take the first and last valid height (ISO 13473-1 has no
        neighbour to interpolate from there).
        """
        z = self.heights
        missing = np.isnan(z)
        if not missing.any():
            return self._with(z.copy(), step="fill_dropouts(): no drop-outs")
        filled = z.copy()
        filled[missing] = np.interp(self.positions[missing], self.positions[~missing], z[~missing])
        return self._with(filled, step=f"fill_dropouts(): {int(missing.sum())} readings interpolated linearly")

    def resample(self, dx: float) -> "Profile":
        """A uniform profile of spacing ``dx`` (m), each new height the mean of the valid readings in
        its interval (the ISO 13473-1 resampling; averaging is also the anti-alias filter).

        Each raw reading stands for the interval of one nominal dx around it, so the new grid tiles
        [positions[0] - dx_raw/2, positions[-1] + dx_raw/2) from its left edge and new positions
        are interval centres; resampling at the profile's own spacing is the identity. An interval
        with no valid reading is a drop-out (NaN): that includes every other interval when ``dx`` is
        finer than the data, which :meth:`fill_dropouts` then interpolates.
        """
        new_dx = positive(dx, "dx")
        left = self.positions[0] - 0.5 * self.dx
        n_bins = max(1, int(math.ceil(self.length / new_dx - 1e-9)))
        scaled = self.positions - left
        scaled *= 1.0 / new_dx
        scaled += 1e-9
        bins = np.floor(scaled, out=scaled).astype(np.int64)
        np.clip(bins, 0, n_bins - 1, out=bins)
        if n_bins == bins.size and bins[0] == 0 and np.all(np.diff(bins) == 1):
            z = self.heights.copy()  # one reading per interval: averaging changes nothing
            empty = int(np.count_nonzero(np.isnan(z)))
        else:
            valid = ~np.isnan(self.heights)
            sums = np.bincount(bins[valid], weights=self.heights[valid], minlength=n_bins)
            counts = np.bincount(bins[valid], minlength=n_bins)
            with np.errstate(invalid="ignore", divide="ignore"):
                z = sums / counts
            empty = int(np.count_nonzero(counts == 0))
        x = left + new_dx * (np.arange(n_bins) + 0.5)
        step = (f"resample(dx={_fmt(new_dx)} m): {self.heights.size} -> {n_bins} samples by interval averaging, "
                f"{empty} empty intervals")
        return self._with(z, x, new_dx, step=step)

    def detrend(self, kind: Literal["linear", "mean"] = "linear") -> "Profile":
        """Removes the least-squares line (``"linear"``, slope suppression) or the mean (``"mean"``)
        fitted to the valid readings. Drop-outs stay NaN."""
        if kind not in ("linear", "mean"):
            raise ValueError(f"kind must be 'linear' or 'mean', got {kind!r}")
        z, x = self.heights, self.positions
        valid = ~np.isnan(z)
        if kind == "mean":
            offset = float(np.mean(z[valid]))
            return self._with(z - offset, step=f"detrend(mean): removed {_fmt(offset)} m")
        slope, intercept = _line_fit(x[valid], z[valid])
        step = f"detrend(linear): removed slope {_fmt(slope)} and offset {_fmt(intercept)} m at x=0"
        return self._with(z - (slope * x + intercept), step=step)

    def lowpass(self, cutoff_wavelength: float = 2.4e-3) -> "Profile":
        """Zero-phase low-pass filter: a 2nd-order Butterworth section run forwards and backwards
        (ISO 13473-1:2019 Annex D; gain 1/2 at ``cutoff_wavelength``, m). Needs a uniform, NaN-free
        profile (after :meth:`resample` and :meth:`fill_dropouts`)."""
        return self._filtered(cutoff_wavelength, "low")

    def highpass(self, cutoff_wavelength: float = 0.1742) -> "Profile":
        """Zero-phase 2nd-order Butterworth high-pass (gain 1/2 at ``cutoff_wavelength``, m): slope
        suppression for continuous measurements. Needs a uniform, NaN-free profile."""
        return self._filtered(cutoff_wavelength, "high")

    def _filtered(self, cutoff_wavelength: float, kind: str) -> "Profile":
        wavelength = positive(cutoff_wavelength, "cutoff_wavelength")
        self._require_grid(f"{kind}pass")
        if wavelength <= 2.0 * self.dx:
            raise ValueError(f"cutoff_wavelength {wavelength:.3g} m must exceed twice dx ({2 * self.dx:.3g} m)")
        z = _filtfilt(self.heights, self.dx, wavelength, kind)
        return self._with(z, step=f"{kind}pass(cutoff_wavelength={_fmt(wavelength)} m): 2nd-order Butterworth, zero phase")

    def _require_grid(self, what: str) -> None:
        if np.isnan(self.heights).any():
            raise ValueError(f"{what} needs a profile without drop-outs: call fill_dropouts() or conditioned() first")
        if not self.is_uniform:
            raise ValueError(f"{what} needs uniform sampling: call resample(dx) or conditioned() first")

    # ---------------------------------------------------------------------------------------------
    def conditioned(self, *, dx: float | None = None, spike_alpha: float | None = 3.0,
                    trim_plates: bool = True, lowpass_wavelength: float | None = None,
                    detrend: Literal["linear", "mean"] | None = "linear") -> "Profile":
        """The standard chain: a uniform, NaN-free profile ready for the contact model.

        Steps, in the order ISO 13473-1 applies them before computing MPD:

        1. ``trim_plates``: :meth:`trim_reference_plates` (does nothing where there are none);
        2. :meth:`resample` to ``dx`` (m; None keeps the profile's nominal dx) by interval averaging;
        3. ``spike_alpha``: :meth:`remove_spikes` on the resampled profile (None skips it);
        4. :meth:`fill_dropouts`, linear, ends held at the nearest valid value;
        5. ``lowpass_wavelength``: optional :meth:`lowpass` (m). ISO applies 2.4 mm for MPD; it is
           off by default because the contact model needs the short wavelengths;
        6. ``detrend``: remove the least-squares line (``"linear"``) or the mean, or None.

        The spike criterion compares adjacent samples, so its alpha means what the standard means
        only at a 0.5 or 1 mm spacing; at a finer dx raise alpha or pass None.
        """
        profile = self.trim_reference_plates() if trim_plates else self
        profile = profile.resample(profile.dx if dx is None else dx)
        if spike_alpha is not None:
            profile = profile.remove_spikes(spike_alpha)
        profile = profile.fill_dropouts()
        if lowpass_wavelength is not None:
            profile = profile.lowpass(lowpass_wavelength)
        if detrend is not None:
            profile = profile.detrend(detrend)
        return profile

    def segments(self, length: float, overlap: float = 0.0, *, detrend: bool = True) -> "Segments":
        """Cuts the profile into equal segments of ``length`` (m) overlapping by ``overlap`` (m).

        The periodic contact model repeats each segment end to start, so a segment's mean slope
        would come back as a sawtooth and its ends would meet at an artificial step. With
        ``detrend`` (the default) the least-squares line of each segment is removed, which
        removes the slope and on average most of the end mismatch; the removed lines are kept in
        :attr:`Segments.trends` so results in the profile's frame can be restored. The ends of a
        segment are still a seam for the model: use an overlap and :meth:`Segments.stitch` to fade
        them out.

        Segments start every ``length - overlap``; when that does not end exactly at the end of the
        profile, one last segment ends flush with the profile, so every sample is covered.

        Needs a uniform, NaN-free profile (:meth:`conditioned`).
        """
        self._require_grid("segments")
        length_f = positive(length, "length")
        overlap_f = finite_number(overlap, "overlap")
        points = int(round(length_f / self.dx))
        overlap_points = int(round(overlap_f / self.dx))
        if points < 2:
            raise ValueError(f"segment length {length_f:.3g} m is less than 2 samples of dx {self.dx:.3g} m")
        if not 0 <= overlap_points < points:
            raise ValueError(f"overlap must be in [0, length), got {overlap_f!r} m for length {length_f!r} m")
        n = self.heights.size
        if points > n:
            raise ValueError(f"segment length {length_f:.6g} m exceeds the profile ({self.length:.6g} m)")
        step = points - overlap_points
        starts = list(range(0, n - points + 1, step))
        if starts[-1] + points < n:
            starts.append(n - points)
        start_index = np.asarray(starts, dtype=np.int64)
        take = start_index[:, None] + np.arange(points)[None, :]
        heights = self.heights[take]
        trends = np.zeros_like(heights)
        if detrend:
            local_x = (np.arange(points) - 0.5 * (points - 1)) * self.dx
            slope = heights @ local_x / float(local_x @ local_x)
            trends = heights.mean(axis=1)[:, None] + slope[:, None] * local_x[None, :]
            heights = heights - trends
        return Segments(heights=heights, starts=self.positions[start_index], dx=self.dx,
                        length=points * self.dx, overlap=overlap_points * self.dx, trends=trends,
                        start_indices=start_index, profile_positions=self.positions)


def _line_fit(x: np.ndarray, z: np.ndarray) -> tuple[float, float]:
    if x.size < 2:
        return 0.0, float(z.mean())
    xm, zm = x.mean(), z.mean()
    dxs = x - xm
    denominator = float(dxs @ dxs)
    slope = float(dxs @ (z - zm)) / denominator if denominator > 0 else 0.0
    return slope, float(zm - slope * xm)


@dataclass(frozen=True)
class Segments:
    """Equal-length segments of a uniform profile, for :func:`roadtex.contact_many`.

    Attributes:
        heights: (n_segments, points_per_segment) heights (m), NaN-free, each segment's linear
            trend removed unless ``detrend=False`` was asked.
        starts: (n_segments,) position of each segment's first sample (m).
        dx, length, overlap: sampling (m), segment length (m, points * dx), nominal overlap (m).
        trends: (n_segments, points_per_segment) the line removed from each segment (m; zeros
            when not detrended): ``heights + trends`` are the profile's own heights.
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
            raise ValueError(f"values must have shape {self.heights.shape} (segments, points), got {array.shape}")
        if method not in ("crossfade", "centre"):
            raise ValueError(f"method must be 'crossfade' or 'centre', got {method!r}")
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
# reading

def _decode(raw: bytes, encoding: str | None, name: str) -> tuple[bytes, str]:
    """Returns the content as UTF-8 bytes with '\\n' line ends, and the encoding used."""
    if not raw or raw.isspace():
        raise ValueError(f"{name} is empty")
    if encoding is not None:
        try:
            text = raw.decode(encoding)
        except (LookupError, UnicodeDecodeError) as exc:
            raise ValueError(f"{name} cannot be decoded as {encoding}: {exc}") from None
        data, used = text.encode("utf-8"), encoding
    elif raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            data, used = raw.decode("utf-16").encode("utf-8"), "utf-16"
        except UnicodeDecodeError as exc:
            raise ValueError(f"{name} has a UTF-16 byte-order mark but is not valid UTF-16: {exc}") from None
    elif raw.startswith(b"\xef\xbb\xbf"):
        data, used = raw[3:], "utf-8"
    else:
        head = raw[:4096]
        if b"\x00" in head:
            if head[1::2].count(0) > 0.4 * len(head[1::2]):
                hint = "UTF-16 (little-endian) without a byte-order mark: pass encoding='utf-16-le'"
            elif head[0::2].count(0) > 0.4 * len(head[0::2]):
                hint = "UTF-16 (big-endian) without a byte-order mark: pass encoding='utf-16-be'"
            else:
                hint = "binary data, not a text profile"
            raise ValueError(f"{name} looks like {hint}")
        try:
            if not raw.isascii():
                raw.decode("utf-8")
            data, used = raw, "utf-8"
        except UnicodeDecodeError:
            # Old instrument software writes Windows-1252/Latin-1 (a degree sign or umlaut in a header).
            data, used = raw.decode("latin-1").encode("utf-8"), "latin-1"
    # The CSV parser takes CRLF as it is; only old Mac files with bare CR need rewriting. Judging
    # by the head spares two passes over a large file (files do not mix line ends in practice).
    first_cr = data.find(b"\r")
    if first_cr >= 0:
        head = data[first_cr:first_cr + 65536]
        if head.count(b"\r") != head.count(b"\r\n"):
            data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    return data, used


def _unit_factor(unit: str, what: str) -> float:
    key = unit.strip().lower()
    if key not in _UNITS:
        raise ValueError(f"unknown unit {unit!r} for {what}; known units: m, mm, cm, um (µm), km, in, ft")
    return _UNITS[key]


def _split_name(column: str) -> tuple[str, str | None]:
    """'Distance (mm)' -> ('distance', 'mm'); 'height_mm' -> ('height', 'mm'); 'z' -> ('z', None)."""
    text = column.strip()
    bracket = re.search(r"[\(\[]\s*([^\)\]]*?)\s*[\)\]]\s*$", text)
    if bracket:
        base = text[:bracket.start()].strip()
        unit: str | None = bracket.group(1)
    else:
        base, unit = text, None
        suffix = re.match(r"^(.*?)[_\s]+([A-Za-zµμ]+)$", text)
        if suffix and suffix.group(2).lower() in _UNITS:
            base, unit = suffix.group(1), suffix.group(2)
    base = re.sub(r"[\s\-]+", "_", base.strip().lower()).rstrip(":")
    return base, unit


def _pick_column(names: list[str], wanted: str | int | None, synonyms: tuple[str, ...], what: str,
                 required: bool) -> int | None:
    if isinstance(wanted, (int, np.integer)) and not isinstance(wanted, bool):
        if not -len(names) <= int(wanted) < len(names):
            raise ValueError(f"{what} column index {wanted} is out of range for {len(names)} columns")
        return int(wanted) % len(names)
    if isinstance(wanted, str):
        for i, name in enumerate(names):
            if name == wanted or name.strip().lower() == wanted.strip().lower() or _split_name(name)[0] == wanted.lower():
                return i
        raise ValueError(f"unknown {what} column {wanted!r}; the columns are {names}")
    if wanted is not None:
        raise ValueError(f"{what}_column must be a column name or index, got {wanted!r}")
    bases = [_split_name(n)[0] for n in names]
    for synonym in synonyms:
        if synonym in bases:
            return bases.index(synonym)
    if required:
        hint = ", or give dx= (m) for evenly spaced heights" if what == "distance" else ""
        raise ValueError(f"no {what} column among {names}; name it with {what}_column={hint}")
    return None


def _column_unit(names: list[str], index: int, given: str | None, what: str) -> float:
    if given is not None:
        return _unit_factor(given, what)
    unit = _split_name(names[index])[1]
    if unit is None:
        raise ValueError(f"no unit for the {what} column {names[index]!r}: give {what}_unit= ('m', 'mm', 'um', ...)")
    return _unit_factor(unit, f"the {what} column {names[index]!r}")


def _nominal_dx(positions: np.ndarray) -> float:
    return float((positions[-1] - positions[0]) / (positions.size - 1)) if positions.size > 1 else 0.0


def _sorted_samples(positions: np.ndarray, heights: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray, str]:
    """Sorts by position; merges exact duplicates that agree; refuses duplicates that conflict."""
    note = ""
    if np.isnan(positions).any():
        raise ValueError(f"{name}: distance is NaN at data row {int(np.flatnonzero(np.isnan(positions))[0]) + 1}")
    steps = np.diff(positions)
    if np.any(steps <= 0):
        order = np.argsort(positions, kind="stable")
        moved = int(np.count_nonzero(order != np.arange(order.size)))
        positions, heights = positions[order], heights[order]
        if moved:
            note = f"; sorted {moved} samples by position"
        same = np.flatnonzero(np.diff(positions) == 0)
        if same.size:
            a, b = heights[same], heights[same + 1]
            conflict = ~((a == b) | np.isnan(a) | np.isnan(b))
            if conflict.any():
                i = int(same[np.flatnonzero(conflict)[0]])
                raise ValueError(f"{name}: {same.size} duplicate positions, e.g. {positions[i]:.9g} m with heights "
                                 f"{heights[i]:.9g} and {heights[i + 1]:.9g} m that disagree: cannot sort them out")
            keep = np.ones(positions.size, dtype=bool)
            keep[same + 1] = False
            # a duplicate pair keeps the valid height of the two
            heights = heights.copy()
            heights[same] = np.where(np.isnan(a), b, a)
            positions, heights = positions[keep], heights[keep]
            note += f"; merged {same.size} duplicate positions"
    return positions, heights, note


def _parse_table(data: bytes, separator: str, n_columns: int, name: str,
                 first_line: int) -> tuple[np.ndarray, np.ndarray]:
    """Numeric table (rows, n_columns) from delimited UTF-8 text, and the mask of missing fields
    (empty or absent; they are NaN in the table, like the written ``NaN`` drop-outs)."""
    schema = {f"c{i}": pl.Float64 for i in range(n_columns)}
    try:
        frame = pl.read_csv(io.BytesIO(data), has_header=False, separator=separator, schema=schema,
                            null_values=["", "NA", "N/A", "null", "-"], comment_prefix=None, quote_char='"')
    except (Exception, pl.exceptions.PanicException) as exc:
        # polars raises ComputeError/NoDataError with a long hint (keep its first line), and on some
        # malformed input (a file cut inside a quoted field) panics: a PanicException, which is a
        # BaseException, so it is named here to be reported as what it is, a bad file.
        message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ValueError(f"{name}: cannot read the numbers after line {first_line}: {message}") from None
    missing = np.column_stack([frame.get_column(c).is_null().to_numpy() for c in frame.columns]) \
        if frame.height else np.zeros((0, n_columns), dtype=bool)
    table = frame.to_numpy().astype(np.float64, copy=False).reshape(frame.height, n_columns)
    return table, missing


def _lines(data: bytes, count: int) -> tuple[list[bytes], list[int]]:
    """The first ``count`` lines and the byte offset where each ends (after its newline)."""
    lines, ends, start = [], [], 0
    while len(lines) < count and start < len(data):
        stop = data.find(b"\n", start)
        stop = len(data) if stop < 0 else stop + 1
        lines.append(data[start:stop].rstrip(b"\r\n"))
        ends.append(stop)
        start = stop
    return lines, ends


def _parse_value(text: str) -> object:
    text = text.strip()
    for cast in (int, float):
        try:
            value = cast(text)
            if isinstance(value, float) and not math.isfinite(value):
                return text
            return value
        except ValueError:
            pass
    return text


_Read = tuple[np.ndarray, np.ndarray, dict, list[str], object]


def _read_captif(data: bytes, name: str, options: dict) -> _Read:
    lines, ends = _lines(data, 64)
    marker = next((i for i, line in enumerate(lines) if line.strip().startswith(_CAPTIF_MARKER)), None)
    if marker is None:
        raise ValueError(f"{name}: not a CAPTIF profile file (no '*****DATA*****' line in its first 64 lines)")
    metadata: dict[str, object] = {}
    for line in lines[:marker]:
        parts = [p.strip() for p in line.decode("utf-8", "replace").split("\t")]
        key = parts[0]
        values = [p for p in parts[1:] if p]
        if not key:
            continue
        metadata[re.sub(r"\W+", "_", key.strip().lower()).strip("_")] = " ".join(values)
    if marker + 1 >= len(lines):
        raise ValueError(f"{name}: CAPTIF file ends after its '*****DATA*****' line (no header, no data)")
    header = [h.strip() for h in lines[marker + 1].decode("utf-8", "replace").split("\t") if h.strip()]
    if len(header) < 3:
        raise ValueError(f"{name}: CAPTIF header line should name 3 columns (point, distance, height), got {header}")
    distance_factor = _unit_factor(_split_name(header[1])[1] or "mm", f"the CAPTIF distance column {header[1]!r}")
    height_factor = _unit_factor(_split_name(header[2])[1] or "mm", f"the CAPTIF height column {header[2]!r}")
    body = data[ends[marker + 1]:]
    if not body or body.isspace():
        raise ValueError(f"{name}: CAPTIF file has a header but no data rows")
    if not body.endswith(b"\n"):
        # The profilometer ends every row with a line end: without one, the file was cut, and
        # possibly inside a number (3.144 read as 3.1), which no per-value check can see.
        raise ValueError(f"{name}: CAPTIF file ends inside a data row (no line end after its last row): "
                         "the file is truncated")
    table, absent = _parse_table(body, "\t", 3, name, marker + 2)
    missing = np.flatnonzero(absent.any(axis=1) | np.isnan(table[:, 1]))
    if missing.size:
        row = int(missing[0])
        raise ValueError(f"{name}: data row {row + 1} (line {marker + 3 + row}) has a missing value "
                         "(truncated or malformed file); drop-outs are written NaN")
    # The file calls it "Depth", but it is a height, positive up (CAPTIF's README).
    positions = table[:, 1] * distance_factor
    heights = table[:, 2] * height_factor
    normalised: dict[str, object] = {
        "format": "captif", "device": "CAPTIF stationary laser profilometer",
    }
    renames = {"road_name": "site", "ref_station": "ref_station", "start_pos_m": "start_position_m",
               "end_pos_m": "end_position_m", "direction": "direction", "wheel_path": "wheel_path",
               "file_no": "file_number", "current_pos": "current_position_m", "date": "date"}
    for key, value in metadata.items():
        target = renames.get(key, key)
        if target == "date":
            match = re.match(r"^(\d{1,2})/(\d{1,2})/(\d{4})(.*)$", str(value))
            if match:
                day, month, year, rest = match.groups()
                normalised["date"] = f"{int(year):04d}-{int(month):02d}-{int(day):02d}"
                if rest.strip():
                    normalised["time"] = rest.strip()
                continue
        normalised[target] = _parse_value(str(value)) if value != "" else None
    return positions, heights, normalised, [], options.get("dx")


def _sniff_separator(lines: list[bytes]) -> str:
    sample = [line for line in lines if line.strip()][:5]
    for separator in ("\t", ";", ","):
        counts = {line.count(separator.encode()) for line in sample}
        if len(counts) == 1 and counts.pop() > 0:
            return separator
    for separator in ("\t", ";", ","):
        if all(separator.encode() in line for line in sample[1:]) and sample[1:]:
            return separator
    return " "


def _is_number(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return text.strip().lower() in ("nan", "", "na", "n/a", "null", "-")


def _read_csv(data: bytes, name: str, options: dict) -> _Read:
    lines, ends = _lines(data, 200)
    metadata: dict[str, object] = {}
    history: list[str] = []
    skip = 0
    for line in lines:
        text = line.decode("utf-8", "replace").strip()
        if not text:
            skip += 1
            continue
        if not text.startswith("#"):
            break
        skip += 1
        body = text.lstrip("#").strip()
        if body.startswith(_ROADTEX_TAG + ":"):
            try:
                stored = json.loads(body[len(_ROADTEX_TAG) + 1:])
            except json.JSONDecodeError as exc:
                raise ValueError(f"{name}: damaged {_ROADTEX_TAG} header line: {exc}") from None
            metadata.update(stored.get("metadata", {}))
            history.extend(stored.get("history", []))
            if stored.get("dx") is not None and options.get("dx") is None:
                options = {**options, "dx": stored["dx"]}
        elif re.match(r"^[^:=]+[:=]", body):
            key, value = re.split(r"[:=]", body, maxsplit=1)
            metadata[re.sub(r"\W+", "_", key.strip().lower()).strip("_")] = _parse_value(value)
    rest = lines[skip:]
    if not rest:
        raise ValueError(f"{name}: no data (only comments or blank lines)")
    separator = options.get("delimiter") or _sniff_separator(rest[:5])
    offset = ends[skip - 1] if skip else 0
    body = data[offset:]
    header_text = rest[0].decode("utf-8", "replace")
    if separator == " ":
        body = re.sub(rb"[ \t]+", b"\t", re.sub(rb"(?m)^[ \t]+|[ \t]+$", b"", body))
        separator = "\t"
        rest = [re.sub(rb"[ \t]+", b"\t", line.strip()) for line in rest]
        # blank-separated headers may hold names with single blanks ("height (mm)"): prefer runs
        # of two or more blanks as separators when that matches the data's column count
        columns = len(rest[1].split(b"\t")) if len(rest) > 1 else len(rest[0].split(b"\t"))
        wide = [f for f in re.split(r"\s{2,}|\t", header_text.strip()) if f]
        if len(wide) == columns:
            rest[0] = "\t".join(wide).encode()
    first = [f.strip().strip('"') for f in rest[0].decode("utf-8", "replace").split(separator)]
    has_header = not all(_is_number(f) for f in first)
    if has_header and len(rest) > 1:
        data_columns = len(rest[1].decode("utf-8", "replace").split(separator))
        if data_columns != len(first):
            raise ValueError(f"{name}: the header names {len(first)} columns ({first}) but the first data row "
                             f"has {data_columns} fields")
    if has_header:
        names = first
        body = body[body.find(b"\n") + 1:] if b"\n" in body else b""
        if not body or body.isspace():
            raise ValueError(f"{name}: a header line ({separator.join(names)!r}) but no data rows")
    else:
        names = [f"column_{i + 1}" for i in range(len(first))]
    n_columns = len(names)
    first_data_line = skip + (2 if has_header else 1)
    if not data.endswith(b"\n"):
        last = body.rstrip(b"\r\n").rsplit(b"\n", 1)[-1]
        if last.count(separator.encode()) < n_columns - 1 or not last.split(separator.encode())[-1].strip():
            raise ValueError(f"{name}: the last line {last[:60].decode('utf-8', 'replace')!r} has fewer than "
                             f"{n_columns} fields and no line end: the file looks truncated")
    table, absent = _parse_table(body, separator, n_columns, name, first_data_line - 1)
    if table.shape[0] == 0:
        raise ValueError(f"{name}: no data rows")
    if has_header:
        h_index = _pick_column(names, options.get("height_column"), _HEIGHT_NAMES, "height", True)
        d_index = _pick_column(names, options.get("distance_column"), _DISTANCE_NAMES, "distance",
                               options.get("dx") is None)
    else:
        h_given, d_given = options.get("height_column"), options.get("distance_column")
        if n_columns == 1:
            h_index, d_index = _pick_column(names, 0 if h_given is None else h_given, (), "height", True), None
        else:
            h_index = _pick_column(names, 1 if h_given is None else h_given, (), "height", True)
            d_index = _pick_column(names, 0 if d_given is None else d_given, (), "distance", False)
    assert h_index is not None
    heights = table[:, h_index] * _column_unit(names, h_index, options.get("height_unit"), "height")
    if d_index is not None:
        if absent[:, d_index].any():
            row = int(np.flatnonzero(absent[:, d_index])[0])
            raise ValueError(f"{name}: data row {row + 1} (line {first_data_line + row}) has no distance")
        positions = table[:, d_index] * _column_unit(names, d_index, options.get("distance_unit"), "distance")
    else:
        positions = _grid_positions(heights.size, options, name)
    metadata.setdefault("format", "csv")
    return positions, heights, metadata, history, options.get("dx")


def _grid_positions(n: int, options: dict, name: str) -> np.ndarray:
    if options.get("dx") is None:
        raise ValueError(f"{name}: heights only (no distance column): give dx= (m)")
    dx = positive(options["dx"], "dx")
    return finite_number(options.get("start", 0.0), "start") + dx * np.arange(n)


def _sidecar(path: Path) -> Path:
    return path.with_name(path.name + ".json")


def _read_npy(path: Path, name: str, options: dict) -> _Read:
    try:
        array = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise ValueError(f"{name}: not a readable .npy array: {exc}") from None
    if array.dtype.kind not in "fiu" or array.size == 0:
        raise ValueError(f"{name}: .npy must hold numbers, got dtype {array.dtype} and {array.size} values")
    metadata: dict[str, object] = {"format": "npy"}
    history: list[str] = []
    options = dict(options)
    sidecar = _sidecar(path)
    if sidecar.exists():
        try:
            stored = json.loads(sidecar.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ValueError(f"{sidecar.name}: damaged metadata file: {exc}") from None
        metadata.update(stored.get("metadata", {}))
        history.extend(stored.get("history", []))
        for key in ("dx", "distance_unit", "height_unit"):
            if options.get(key) is None:
                options[key] = stored.get(key)
    array = array.astype(np.float64)
    height_factor = _unit_factor(options.get("height_unit") or "m", "the .npy heights")
    if array.ndim == 1:
        return _grid_positions(array.size, options, name), array * height_factor, metadata, history, options.get("dx")
    if array.ndim == 2 and 2 in array.shape:
        pairs = array if array.shape[1] == 2 else array.T
        distance_factor = _unit_factor(options.get("distance_unit") or "m", "the .npy distances")
        return pairs[:, 0] * distance_factor, pairs[:, 1] * height_factor, metadata, history, options.get("dx")
    raise ValueError(f"{name}: .npy must be 1-D heights or (N, 2) distance/height pairs, got shape {array.shape}")


def _read_parquet(path: Path, name: str, options: dict) -> _Read:
    try:
        frame = pl.read_parquet(path)
        stored_meta = pl.read_parquet_metadata(path)
    except Exception as exc:
        message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ValueError(f"{name}: not a readable Parquet file: {message}") from None
    if frame.height == 0:
        raise ValueError(f"{name}: Parquet table has no rows")
    metadata: dict[str, object] = {"format": "parquet"}
    history: list[str] = []
    options = dict(options)
    if _ROADTEX_TAG in stored_meta:
        stored = json.loads(stored_meta[_ROADTEX_TAG])
        metadata.update(stored.get("metadata", {}))
        history.extend(stored.get("history", []))
        if options.get("dx") is None:
            options["dx"] = stored.get("dx")
    names = frame.columns
    h_index = _pick_column(names, options.get("height_column"), _HEIGHT_NAMES, "height", True)
    d_index = _pick_column(names, options.get("distance_column"), _DISTANCE_NAMES, "distance", options.get("dx") is None)
    assert h_index is not None

    def column(index: int) -> np.ndarray:
        series = frame.get_column(names[index])
        if not series.dtype.is_numeric():
            raise ValueError(f"{name}: column {names[index]!r} is {series.dtype}, not numeric")
        return series.cast(pl.Float64).fill_null(float("nan")).to_numpy()

    heights = column(h_index) * _column_unit(names, h_index, options.get("height_unit"), "height")
    if d_index is None:
        return _grid_positions(heights.size, options, name), heights, metadata, history, options.get("dx")
    positions = column(d_index) * _column_unit(names, d_index, options.get("distance_unit"), "distance")
    return positions, heights, metadata, history, options.get("dx")


def _guess_format(path: Path, head: bytes) -> str:
    if head.startswith(b"\x93NUMPY"):
        return "npy"
    if head.startswith(b"PAR1"):
        return "parquet"
    suffix = path.suffix.lower()
    if suffix == ".npy":
        return "npy"
    if suffix in (".parquet", ".pq"):
        return "parquet"
    if _CAPTIF_MARKER in head or _CAPTIF_MARKER in _utf16_ascii(head):
        return "captif"
    return "csv"


def _utf16_ascii(head: bytes) -> bytes:
    return head.replace(b"\x00", b"")


def read_profile(path: str | Path, format: str | None = None, **options: object) -> Profile:
    """Reads a road profile file into a :class:`Profile` in metres, drop-outs as NaN.

    Formats (``format=None`` guesses from the content, then the suffix):

    - ``"captif"``: the CAPTIF stationary laser profilometer text file: tab-separated metadata
      lines, ``*****DATA*****``, a header ``Data Point No: / Distance (mm) / Depth (mm)``, rows of
      point, distance, height. The third column is a height, positive up, whatever its name.
      Metadata (site, wheel_path, direction, date as ISO yyyy-mm-dd, file_number, ...) is kept.
    - ``"csv"``: delimited text (``.csv``, ``.tsv``, ``.txt``, ...): the delimiter (tab, ``;``,
      ``,`` or blanks) is sniffed, a header is detected. Columns are found by name (distance,
      position, x, chainage / height, z, elevation, profile) or given; units come from the header
      (``"height (mm)"``, ``"height [um]"``, ``"z_mm"``) or are given. Leading ``# key: value``
      lines become metadata. Without a header, the first column is distance and the second height.
      Empty fields are drop-outs.
    - ``"npy"``: 1-D heights (needs ``dx``) or (N, 2) distance/height pairs, in metres unless units
      are given; a ``<file>.npy.json`` sidecar written by :func:`write_profile` adds metadata.
    - ``"parquet"``: a table with distance and height columns, found and scaled as for CSV.

    Options: ``distance_column``, ``height_column`` (name or index), ``distance_unit``,
    ``height_unit`` (``"m"``, ``"mm"``, ``"um"``, ...), ``dx`` (m, for heights-only data; also the
    nominal dx to record), ``start`` (m, first position for heights-only data), ``delimiter``,
    ``encoding`` (text files; UTF-8, UTF-16 with a byte-order mark and Latin-1 are recognised),
    ``sort`` (default True: out-of-order rows are sorted by position; False refuses them).

    Rows are sorted by position; exact duplicates that agree are merged.

    Raises:
        ValueError: the file is missing, empty, binary or in an unknown encoding, truncated, has no
            usable distance or height column or an unknown unit, holds only drop-outs, or has
            duplicate positions with conflicting heights (the message names the problem).
    """
    file = Path(path)
    name = file.name
    known = {"distance_column", "height_column", "distance_unit", "height_unit", "dx", "start",
             "delimiter", "encoding", "sort"}
    unknown = set(options) - known
    if unknown:
        raise ValueError(f"unknown option(s) {sorted(unknown)}; known: {sorted(known)}")
    if format is not None and format not in _FORMATS:
        raise ValueError(f"unknown format {format!r}; known formats: {', '.join(_FORMATS)}")
    if not file.is_file():
        raise ValueError(f"no such file: {file}")
    if file.stat().st_size == 0:
        raise ValueError(f"{name} is empty")
    with file.open("rb") as handle:
        head = handle.read(8192)
    fmt = format or _guess_format(file, head)
    if fmt == "npy":
        positions, heights, metadata, history, dx = _read_npy(file, name, options)
        encoding = None
    elif fmt == "parquet":
        positions, heights, metadata, history, dx = _read_parquet(file, name, options)
        encoding = None
    else:
        data, encoding = _decode(file.read_bytes(), options.get("encoding"), name)  # type: ignore[arg-type]
        reader = _read_captif if fmt == "captif" else _read_csv
        positions, heights, metadata, history, dx = reader(data, name, options)
    if positions.size < 2:
        raise ValueError(f"{name}: {positions.size} data row(s): a profile needs at least 2")
    if np.isinf(heights).any() or np.isinf(positions).any():
        row = int(np.flatnonzero(np.isinf(heights) | np.isinf(positions))[0])
        raise ValueError(f"{name}: data row {row + 1} holds an infinite or overflowing value")
    if np.isnan(heights).all():
        raise ValueError(f"{name}: all {heights.size} heights are drop-outs (NaN)")
    if options.get("sort", True) is False and np.any(np.diff(positions) <= 0):
        raise ValueError(f"{name}: positions are not strictly increasing (pass sort=True to sort them)")
    positions, heights, note = _sorted_samples(positions, heights, name)
    if positions.size < 2:
        raise ValueError(f"{name}: fewer than 2 distinct positions")
    dx_f = positive(dx, "dx") if dx is not None else _nominal_dx(positions)
    metadata.setdefault("source", name)
    encoding_note = f", {encoding}" if encoding not in (None, "utf-8") else ""
    history.append(f"read_profile({name!r}, format={fmt!r}{encoding_note}): {positions.size} samples, "
                   f"dx {_fmt(dx_f)} m, {int(np.count_nonzero(np.isnan(heights)))} drop-outs{note}")
    return Profile(heights, positions, dx_f, metadata, tuple(history))


# --------------------------------------------------------------------------------------------------
# writing

def _json_safe(metadata: dict[str, object]) -> dict[str, object]:
    safe: dict[str, object] = {}
    for key, value in metadata.items():
        try:
            json.dumps(value, allow_nan=False)
            safe[str(key)] = value
        except (TypeError, ValueError):
            safe[str(key)] = str(value)
    return safe


def write_profile(profile: Profile, path: str | Path, format: str | None = None) -> Path:
    """Writes ``profile`` so that :func:`read_profile` gives back the same heights, positions
    (bit for bit), dx, metadata and history (plus one line recording the read).

    Formats (``None`` takes it from the suffix: ``.csv``/``.txt``/``.tsv``, ``.npy``, ``.parquet``):
    ``"csv"`` with a ``# roadtex-profile: {json}`` first line and columns ``distance (m)``,
    ``height (m)`` (tab-separated for ``.tsv``); ``"npy"`` as an (N, 2) array of metres plus a
    ``<file>.npy.json`` sidecar for the metadata; ``"parquet"`` with columns ``distance_m``,
    ``height_m`` and the metadata in the file's key-value metadata. Metadata values that are not
    JSON types are written as strings. Drop-outs are written NaN.

    Returns:
        The path written.
    """
    if not isinstance(profile, Profile):
        raise ValueError(f"profile must be a roadtex Profile, got {type(profile).__name__}")
    file = Path(path)
    suffix = file.suffix.lower()
    if format is None:
        format = {".csv": "csv", ".txt": "csv", ".tsv": "csv", ".npy": "npy", ".parquet": "parquet",
                  ".pq": "parquet"}.get(suffix)
        if format is None:
            raise ValueError(f"cannot tell the format from the suffix {suffix!r}: give format='csv', 'npy' or 'parquet'")
    if format not in ("csv", "npy", "parquet"):
        raise ValueError(f"write_profile writes 'csv', 'npy' or 'parquet', got {format!r}")
    stored = {"metadata": _json_safe(profile.metadata), "history": list(profile.history), "dx": profile.dx}
    positions = np.asarray(profile.positions)
    heights = np.asarray(profile.heights)
    if format == "csv":
        separator = "\t" if suffix == ".tsv" else ","
        frame = pl.DataFrame({"distance (m)": positions, "height (m)": heights})
        with file.open("w", encoding="utf-8", newline="\n") as handle:
            handle.write(f"# {_ROADTEX_TAG}: {json.dumps(stored)}\n")
            frame.write_csv(handle, separator=separator, float_scientific=None)
    elif format == "npy":
        np.save(file, np.column_stack([positions, heights]), allow_pickle=False)
        _sidecar(file).write_text(json.dumps({**stored, "distance_unit": "m", "height_unit": "m"}), encoding="utf-8")
    else:
        frame = pl.DataFrame({"distance_m": positions, "height_m": heights})
        frame.write_parquet(file, metadata={_ROADTEX_TAG: json.dumps(stored)})
    return file
