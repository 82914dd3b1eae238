"""The road profile: heights and positions in metres, with what produced them.

A :class:`Profile` holds heights and positions in metres, with NaN marking drop-outs (readings the
laser did not get). Every conditioning step returns a new profile and appends a line to its
``history``, so a result says how it was obtained.

The steps themselves live in :mod:`roadtex.profiles.conditioning`, segments in
:mod:`roadtex.profiles.segments`, readers in :mod:`roadtex.profiles.readers`.
"""


from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Literal

import numpy as np

from roadtex._checks import finite_number, positive, real_values
from roadtex.errors import InvalidInputError
from roadtex.profiles import conditioning
from roadtex.profiles.plausibility import warn_if_implausible_texture
from roadtex.profiles.segments import SegmentDetrend, Segments, cut_segments

# Above this magnitude (m) a height or position is a wrong unit or a corrupt file, not a road, and
# sums of squares over millions of samples would start to lose meaning.
MAX_MAGNITUDE = 1e9


def as_1d(values: object, name: str) -> np.ndarray:
    """A float64 copy of ``values``, refused unless it is 1-D and numeric."""
    values = real_values(values, name, masked="dropouts")   # masked values are drop-outs (NaN); complex refused
    try:
        array = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be numeric: {exc}") from None
    if array.ndim != 1:
        raise InvalidInputError(f"{name} must be a 1-D array, got an array of shape {array.shape}")
    return array


def frozen(array: np.ndarray) -> np.ndarray:
    """``array`` made read-only (profiles never change in place)."""
    array.flags.writeable = False
    return array


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
        heights = as_1d(self.heights, "heights")
        positions = as_1d(self.positions, "positions")
        if heights.size != positions.size:
            raise InvalidInputError(f"heights and positions must have the same length, got {heights.size} and {positions.size}")
        if heights.size < 2:
            raise InvalidInputError(f"a profile needs at least 2 samples, got {heights.size}")
        if not np.all(np.isfinite(positions)):
            raise InvalidInputError("positions must be finite (no NaN or inf)")
        if np.isinf(heights).any():
            raise InvalidInputError(f"heights contain inf at sample {int(np.flatnonzero(np.isinf(heights))[0])} "
                             "(overflow in the source?); drop-outs must be NaN")
        if np.isnan(heights).all():
            raise InvalidInputError("all heights are NaN (drop-outs): no valid reading in the profile")
        biggest = max(float(np.nanmax(np.abs(heights))), float(np.max(np.abs(positions))))
        if biggest > MAX_MAGNITUDE:
            raise InvalidInputError(f"a height or position of {biggest:.3g} m is beyond {MAX_MAGNITUDE:.0g} m: "
                             "not a road profile (wrong unit or a corrupt file?)")
        steps = np.diff(positions)
        if not np.all(steps > 0):
            bad = int(np.flatnonzero(steps <= 0)[0])
            kind = "duplicate" if steps[bad] == 0 else "decreasing"
            raise InvalidInputError(f"positions must be strictly increasing: {kind} position at sample {bad + 1} "
                             f"({positions[bad]:.9g} m then {positions[bad + 1]:.9g} m)")
        dx = positive(self.dx, "dx")
        object.__setattr__(self, "heights", frozen(heights))
        object.__setattr__(self, "positions", frozen(positions))
        object.__setattr__(self, "dx", dx)
        object.__setattr__(self, "metadata", dict(self.metadata))
        object.__setattr__(self, "history", tuple(str(h) for h in self.history))

    # ---------------------------------------------------------------------------------------------
    @classmethod
    def from_heights(cls, heights: Iterable[float] | np.ndarray, dx: float, *, start: float = 0.0,
                     metadata: dict[str, object] | None = None, history: Iterable[str] = ()) -> "Profile":
        """A uniform profile from heights (m) on a grid of spacing ``dx`` (m) starting at ``start`` (m)."""
        z = as_1d(heights, "heights")
        dx_f = positive(dx, "dx")
        x = finite_number(start, "start") + dx_f * np.arange(z.size)
        profile = cls(z, x, dx_f, dict(metadata or {}), tuple(history))
        warn_if_implausible_texture(profile.heights, dx_f, "heights")
        return profile

    def derive(self, heights: np.ndarray, positions: np.ndarray | None = None, dx: float | None = None,
               step: str = "") -> "Profile":
        """A new profile from a conditioning step of this one (heights m, positions m, dx m, one
        history line). The steps keep the invariants (positions
        increasing and finite, no inf, some valid height), so the checks of __init__, a good part
        of the cost on millions of samples, are skipped."""
        new = object.__new__(Profile)
        new_positions = self.positions if positions is None else positions
        for name, value in (("heights", frozen(np.ascontiguousarray(heights, dtype=np.float64))),
                            ("positions", frozen(np.ascontiguousarray(new_positions, dtype=np.float64))),
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
        ends; the road section of interest lies between them. A plate is a long, flat stretch far
        from the road at an end of the run: readings more than ``threshold`` (m) above the road
        next to it, drop-outs inside it included (the laser often loses the plate's top), at least
        10 mm long, with at least 5 such readings spread by at most 5 mm, lying wholly (both
        edges) within 0.25 m of the run's start or end (the constants ``PLATE_*`` of
        :mod:`roadtex.profiles.conditioning`). The road next to it is a resistant line through the
        road over the 0.5 m just inside that end zone, extended over the zone: a grade or a
        vertical curve is never a plate. A single high reading, or anything further from the
        ends, is never a plate: it is a spike, for :meth:`remove_spikes` or
        :func:`roadtex.profiles.conditioning.clean`. The profile
        keeps what lies between the plates, moved inwards by ``margin`` (m) to drop the plate's
        edge. Without plates the profile is kept whole; the step is still recorded.

        Raises:
            ValueError: nothing would be left between the plates.
        """
        return conditioning.trim_reference_plates(self, threshold=threshold, margin=margin)

    def remove_spikes(self, alpha: float = 3.0) -> "Profile":
        """Flags spikes as drop-outs (NaN), with the ISO 13473-1:2019 (Annex E) criterion.

        A jump between consecutive valid readings i-1, i is a spike when
        |z_i - z_(i-1)| >= alpha * (x_i - x_(i-1)): a slope steeper than ``alpha`` (3 in the
        standard, about 72 degrees). Both readings of the jump are flagged, as in the standard and
        in captif-slp. The criterion is meant for profiles resampled to 0.5 or 1 mm; on finer raw
        sampling it also flags steep but real stone edges. Alpha = 6 suits coarse chip seals
        measured by the CAPTIF laser (its authors' setting).
        """
        return conditioning.remove_spikes(self, alpha)

    def fill_dropouts(self) -> "Profile":
        """Replaces drop-outs (NaN) by linear interpolation between the nearest valid readings.

        Leading and trailing drop-outs take the first and last valid height (ISO 13473-1 has no
        neighbour to interpolate from there).
        """
        return conditioning.fill_dropouts(self)

    def resample(self, dx: float) -> "Profile":
        """A uniform profile of spacing ``dx`` (m), each new height the mean of the valid readings in
        its interval (the ISO 13473-1 resampling; averaging is also the anti-alias filter).

        Averaging over ``dx`` also damps the short wavelengths it keeps, by the amplitude gain
        sinc(dx / wavelength) of a moving average: -0.9 dB at 4 dx, -2.4 dB at 2.5 dx (the shortest
        band reported at that sampling). The bulk job's error budget counts this among the effects of
        the sampling it chooses; results at a coarser ``dx`` than the data carry it.

        Each raw reading stands for the interval of one nominal dx around it, so the new grid tiles
        [positions[0] - dx_raw/2, positions[-1] + dx_raw/2) from its left edge and new positions
        are interval centres; resampling at the profile's own spacing is the identity. An interval
        with no valid reading is a drop-out (NaN): that includes every other interval when ``dx`` is
        finer than the data, which :meth:`fill_dropouts` then interpolates.
        """
        return conditioning.resample(self, dx)

    def detrend(self, kind: Literal["linear", "mean"] = "linear") -> "Profile":
        """Removes the least-squares line (``"linear"``, slope suppression) or the mean (``"mean"``)
        fitted to the valid readings. Drop-outs stay NaN."""
        return conditioning.detrend(self, kind)

    def lowpass(self, cutoff_wavelength: float = 2.4e-3) -> "Profile":
        """Zero-phase low-pass filter: a 2nd-order Butterworth section run forwards and backwards
        (ISO 13473-1:2019 Annex D; gain 1/2 at ``cutoff_wavelength``, m). Needs a uniform, NaN-free
        profile (after :meth:`resample` and :meth:`fill_dropouts`)."""
        return conditioning.zero_phase_filter(self, cutoff_wavelength, "low")

    def highpass(self, cutoff_wavelength: float = 0.1742) -> "Profile":
        """Zero-phase 2nd-order Butterworth high-pass (gain 1/2 at ``cutoff_wavelength``, m): slope
        suppression for continuous measurements. Needs a uniform, NaN-free profile."""
        return conditioning.zero_phase_filter(self, cutoff_wavelength, "high")

    def conditioned(self, *, dx: float | None = None, spike_alpha: float | None = 3.0,
                    trim_plates: bool = True, lowpass_wavelength: float | None = None,
                    detrend: Literal["linear", "mean"] | None = "linear") -> "Profile":
        """The standard chain: a uniform, NaN-free profile ready for the contact model.

        1. ``trim_plates``: :meth:`trim_reference_plates` (does nothing where there are none);
        2. ``spike_alpha``: gross outliers and spikes flagged as drop-outs on the raw readings, by
           :func:`roadtex.profiles.conditioning.clean`'s criterion (a reading at least alpha x
           0.5 mm away from the median of the readings within 0.5 mm), which means what
           ISO 13473-1's alpha means on its 0.5 mm grid whatever the sampling (None skips it);
        3. :meth:`resample` to ``dx`` (m; None keeps the profile's nominal dx) by interval averaging;
        4. :meth:`fill_dropouts`, linear, ends held at the nearest valid value;
        5. ``lowpass_wavelength``: optional :meth:`lowpass` (m). ISO applies 2.4 mm for MPD; it is
           off by default because the contact model needs the short wavelengths;
        6. ``detrend``: remove the least-squares line (``"linear"``) or the mean, or None.

        :func:`roadtex.profiles.conditioning.clean` does steps 1 and 2 and also returns what they
        removed; the bulk job reports it per run.
        """
        profile, _ = conditioning.clean(self, spike_alpha=spike_alpha, trim_plates=trim_plates)
        return profile.finished(dx=dx, lowpass_wavelength=lowpass_wavelength, detrend=detrend)

    def finished(self, *, dx: float | None = None, lowpass_wavelength: float | None = None,
                 detrend: Literal["linear", "mean"] | None = "linear") -> "Profile":
        """Steps 3 to 6 of :meth:`conditioned`: resampled to ``dx`` (m; None: the nominal dx),
        drop-outs filled, optionally low-passed (m) and detrended."""
        profile = self.resample(self.dx if dx is None else dx).fill_dropouts()
        if lowpass_wavelength is not None:
            profile = profile.lowpass(lowpass_wavelength)
        if detrend is not None:
            profile = profile.detrend(detrend)
        return profile

    def segments(self, length: float, overlap: float = 0.0, *,
                 detrend: SegmentDetrend | bool = "ends") -> Segments:
        """Cuts the profile into equal segments of ``length`` (m) overlapping by ``overlap`` (m).

        The periodic contact model and periodic band levels repeat each segment end to start, so
        a segment's mean slope would come back as a sawtooth and any difference between its ends
        as a step at every wrap, whose power (falling as 1/k^2) inflates every band, the short
        ones most. ``detrend="ends"`` (the default; ``True`` is the same) removes the line through
        each segment's first and last sample and its mean: the ends then meet, and the periodic
        extension has no step. ``"least_squares"`` removes the least-squares line instead, which
        removes the slope but leaves the ends differing by the texture there (a step of 0.6 to
        0.8 mm rms on dense asphalt, 2.4 to 3.2 mm on porous asphalt and CAPTIF in 0.5 m
        segments); ``False`` keeps the heights. The seamless line has a cost where an end sample
        lies in a pore: the stone tops the rubber rests on then step at the wrap (on porous
        asphalt the enveloped levels from 20 to 40 mm read 0.2 to 1.3 dB higher; docs/theory.md,
        "Seamless segments"). The removed lines are kept in :attr:`Segments.trends` so results in the
        profile's frame can be restored (``heights + trends`` are the profile's heights). The ends
        of a segment are still where the model's periodic image begins: use an overlap and
        :meth:`Segments.stitch` to fade them out.

        Segments start every ``length - overlap``; when that does not end exactly at the end of the
        profile, one last segment ends flush with the profile, so every sample is covered.

        Needs a uniform, NaN-free profile (:meth:`conditioned`).
        """
        return cut_segments(self, length, overlap, detrend=detrend)
