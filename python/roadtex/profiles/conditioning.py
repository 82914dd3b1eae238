"""Conditioning steps for a :class:`~roadtex.profiles.profile.Profile`, in ISO 13473-1's order:
reference plates trimmed, resampling, spikes, drop-outs, filters, detrending; and :func:`clean`, the
bulk job's cleaning before the contact model: reference plates and spikes, found by criteria that
mean the same at any sampling interval, and counted so that nothing is removed silently.

- **Reference plates** (stationary profilometers such as CAPTIF's put one at each end) are long,
  flat stretches far above the road next to them, lying wholly within 0.25 m of an end of the run,
  often mostly drop-outs (the laser loses the plate's top). The road next to them is a line
  through the road just inside that end zone, so a grade or a vertical curve is never a plate;
  nor is a single high reading.
- **Spikes** are readings that depart from the median of the readings within half a millimetre
  (ISO 13473-1's 0.5 mm grid spacing) by at least ``alpha`` x 0.5 mm: on a 0.5 mm grid this flags
  the same isolated spikes as the standard's slope criterion (a jump of alpha x 0.5 mm between
  neighbours), but a running median keeps steps (stone edges) whatever the sampling, where the
  standard's criterion applied to 0.04 mm samples would flag every steep edge. Readings far outside
  the run's own height range (a laser's "deep" drop-out code such as -850 mm, over any width) are
  removed too.

What is removed becomes a drop-out (NaN), filled later by interpolation; :class:`CleaningSummary`
holds the counts the bulk job reports per run.

Each function returns a new profile and records one history line; :class:`Profile`'s methods of
the same names call them. Filters are scipy.signal's zero-phase Butterworth sections.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Literal, Protocol, TypeVar

import numpy as np

from roadtex._checks import finite_number, positive
from roadtex.errors import ConditioningWarning, InvalidInputError
from roadtex.profiles.trend import line_fits

#: The longest high-pass cut-off, in samples: scipy's Butterworth start-up is singular near 1e9.
MAX_HIGHPASS_STEPS = 1e7
#: The most samples :func:`resample` makes per reading (a grid 1000 times finer than the data):
#: finer adds only interpolated points, and far finer is a unit mistake that would exhaust memory.
MAX_RESAMPLE_FACTOR = 1000

if TYPE_CHECKING:
    from roadtex.profiles.profile import Profile


class Readings(Protocol):
    """A run of height readings (m): a line profile, or a surface (roadtex.surfaces.Surface)."""

    @property
    def heights(self) -> np.ndarray: ...

    def derive(self, heights: np.ndarray, *, step: str = "") -> Any: ...


#: What :func:`flag_outliers_and_spikes` cleans and gives back: a line profile or a surface.
Cleanable = TypeVar("Cleanable", bound=Readings)


def format_number(value: float) -> str:
    """A number as history lines write it: six significant digits."""
    return f"{value:.6g}"


#: A step between consecutive readings longer than this many sampling intervals is a gap: rows
#: missing from the file (an export that dropped its drop-outs instead of writing them as empty
#: fields or NaN). Each grid position inside a gap is a drop-out.
GAP_STEPS = 1.5


#: Rows count as missing only where the rest of the file says so: each gap spans a whole number
#: (>= 2) of steps to within GAP_MULTIPLE_TOLERANCE, the other steps scatter (median absolute
#: deviation) by at most GAP_REGULARITY of their median, and the gaps do not recur at a steady
#: spacing (the intervals between them vary by GAP_PATTERN of their mean or more) and are at most
#: GAP_MAX_SHARE of the steps. Otherwise the
#: file is uneven, not missing rows: jitter, or distances rounded more coarsely than half the
#: sampling (0.15 mm written to 0.1 mm alternates 0.1 and 0.2 mm steps, a "gap" every other step).
GAP_MULTIPLE_TOLERANCE = 0.25
GAP_REGULARITY = 0.1
GAP_PATTERN = 0.2
GAP_MAX_SHARE = 0.3


def gap_mask(steps: np.ndarray, dx: float) -> np.ndarray:
    """Which ``steps`` (m) between sorted readings are gaps of missing rows at sampling ``dx`` (m):
    none unless the file is regular apart from them (see :data:`GAP_MULTIPLE_TOLERANCE`)."""
    none = np.zeros(steps.size, dtype=bool)
    if steps.size == 0 or not dx > 0:
        return none
    gaps = steps > GAP_STEPS * dx
    if not gaps.any() or gaps.sum() > GAP_MAX_SHARE * steps.size:
        return none
    spacing = np.diff(np.flatnonzero(gaps))
    if spacing.size >= 2 and float(spacing.std()) < GAP_PATTERN * float(spacing.mean()):
        return none   # gaps at a steady spacing: the rounding of the distances
    multiple = steps[gaps] / dx
    if np.any(np.abs(multiple - np.rint(multiple)) > GAP_MULTIPLE_TOLERANCE) or np.any(np.rint(multiple) < 2):
        return none
    if float(np.rint(multiple).sum()) > steps.size:
        # more rows "missing" than the file has: a wrong distance (one corrupt value 10^12 steps
        # on), not missing rows; listing them would allocate terabytes (found by fuzzing)
        return none
    regular = steps[~gaps]
    middle = float(np.median(regular))
    if middle <= 0 or float(np.median(np.abs(regular - middle))) > GAP_REGULARITY * middle:
        return none
    return gaps


#: A step over this many sampling intervals (1 m at 1 mm) that :func:`gap_mask` does not read as
#: missing rows is a jump (:func:`distance_jumps`): two runs joined in one file, or a corrupt
#: distance. It is neither rows to fill (it may span more rows than the file holds, or no whole
#: number of steps) nor a sampling interval: averaged into the steps, a 1 km jump in 2 m of 1 mm
#: readings made a 0.5 m "interval", refused as distances in mm read as m.
JUMP_STEPS = 1000


def distance_jumps(positions: np.ndarray) -> np.ndarray:
    """Indices ``i`` of the steps ``positions[i] -> positions[i + 1]`` (sorted, m) that are jumps
    (:data:`JUMP_STEPS`): over 1000 median steps and not a gap of missing rows (:func:`gap_mask`)."""
    x = np.asarray(positions, dtype=np.float64)
    if x.size < 3:
        return np.empty(0, dtype=np.int64)
    steps = np.diff(x)
    typical = float(np.median(steps))
    if not typical > 0:
        return np.empty(0, dtype=np.int64)
    return np.flatnonzero((steps > JUMP_STEPS * typical) & ~gap_mask(steps, typical))


def sampling_interval(positions: np.ndarray) -> float:
    """The nominal sampling interval (m) of sorted reading positions (m): the mean step, each gap
    (a step over :data:`GAP_STEPS` times the median step, in a file regular apart from its gaps:
    :func:`gap_mask`) counted as the whole number of steps it spans. Equal to the mean step,
    (last - first) / (n - 1), when no row is missing."""
    x = np.asarray(positions, dtype=np.float64)
    if x.size < 2:
        return 0.0
    span = float(x[-1] - x[0])
    steps = np.diff(x)
    typical = float(np.median(steps))
    gaps = gap_mask(steps, typical)
    if typical <= 0 or not gaps.any():
        return span / (x.size - 1)
    dx = typical
    for _ in range(2):   # the median step of rounded positions is off by the rounding: count again with the mean
        spanned = float(np.rint(steps[gaps] / dx).sum())
        dx = span / (x.size - 1 - int(gaps.sum()) + spanned)
    return dx


def missing_positions(positions: np.ndarray, dx: float) -> np.ndarray:
    """Grid positions (m) with no row in the file: those inside the gaps (:func:`gap_mask`: steps
    over :data:`GAP_STEPS` ``dx``, m, in a file otherwise regular) between sorted reading positions
    (m). Empty when none is missing."""
    x = np.asarray(positions, dtype=np.float64)
    if x.size < 2 or not dx > 0:
        return np.empty(0)
    steps = np.diff(x)
    gaps = np.flatnonzero(gap_mask(steps, dx))
    if gaps.size == 0:
        return np.empty(0)
    counts = np.rint(steps[gaps] / dx).astype(np.int64) - 1
    return np.concatenate([x[g] + dx * np.arange(1, c + 1) for g, c in zip(gaps, counts) if c > 0] or [np.empty(0)])


#: A plate is at least this far (m) above the road next to it (:func:`road_line`) ...
PLATE_HEIGHT = 0.02
#: ... spans at least this length (m), drop-outs inside it included ...
PLATE_MIN_LENGTH = 0.01
#: ... holds at least this many readings above the road by PLATE_HEIGHT ...
PLATE_MIN_READINGS = 5
#: ... whose spread about their median is at most this (m): plates are flat ...
PLATE_MAX_SPREAD = 0.005
#: ... and lies, both its edges, within this distance (m) of the run's start (end), and in the
#: run's first (second) half.
PLATE_END_ZONE = 0.25
#: The road a plate is judged against: a resistant line through the valid readings over this
#: length (m) next to the end zone (CAPTIF's plates lie within 0.07 m of the ends, road beyond).
PLATE_ROAD_LENGTH = 0.5
#: Fewer valid readings than this next to the end zone (a run shorter than about twice
#: PLATE_END_ZONE): the line is fitted through the whole run's readings instead.
PLATE_ROAD_MIN_READINGS = 30


def road_line(x: np.ndarray, z: np.ndarray) -> tuple[float, float]:
    """Tukey's resistant line through the valid readings ``z`` (m) at positions ``x`` (m, sorted):
    (slope, height at x = 0 in m). The slope joins the medians of the outer thirds, the height is
    the mean of the three thirds' median offsets, so a plate, a pothole or a run of spikes covering
    less than half of a third moves it little, while it follows a grade (and, over the half metre
    it is fitted to, a vertical curve). (0, median) with fewer than three readings; (0, 0) with
    none."""
    valid = ~np.isnan(z)
    xv, zv = x[valid], z[valid]
    if xv.size == 0:
        return 0.0, 0.0
    third = xv.size // 3
    if third == 0:
        return 0.0, float(np.median(zv))
    parts = [slice(0, third), slice(third, xv.size - third), slice(xv.size - third, xv.size)]
    x_med = [float(np.median(xv[part])) for part in parts]
    z_med = [float(np.median(zv[part])) for part in parts]
    slope = (z_med[2] - z_med[0]) / (x_med[2] - x_med[0]) if x_med[2] > x_med[0] else 0.0
    return slope, float(np.mean([zm - slope * xm for xm, zm in zip(x_med, z_med)]))


def plates_at_one_end(profile: Profile, end: Literal["start", "end"], *, height: float, min_length: float,
                      min_readings: int, max_spread: float, end_zone: float) -> list[tuple[int, int]]:
    """The reference plates at one end of the run, as index ranges [start, stop) of the whole run,
    in position order; the criteria are :func:`find_reference_plates`'s."""
    z, x = profile.heights, profile.positions
    mirrored = end == "end"

    def nearest(count: int) -> tuple[np.ndarray, np.ndarray]:
        """The ``count`` readings nearest the end: distances from it (m, increasing) and heights."""
        if mirrored:
            return x[-1] - x[::-1][:count], z[::-1][:count]
        return x[:count] - x[0], z[:count]

    def within(distance: float) -> int:
        """How many readings lie within ``distance`` (m) of the end."""
        if mirrored:
            return x.size - int(np.searchsorted(x, x[-1] - distance, "left"))
        return int(np.searchsorted(x, x[0] + distance, "right"))

    # only the half of the run at this end: the plate, its end zone and the road just inside it
    window = within(min(end_zone + PLATE_ROAD_LENGTH, 0.5 * (x[-1] - x[0])))
    inward, near = nearest(window)
    road = slice(within(end_zone), window)
    if np.count_nonzero(~np.isnan(near[road])) >= PLATE_ROAD_MIN_READINGS:
        slope, offset = road_line(inward[road], near[road])
    else:       # a short run: judged against the line through all of it
        slope, offset = road_line(*nearest(x.size))
    high = near > slope * inward + offset + height      # NaN compares False
    candidate = high | np.isnan(near)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], candidate.astype(np.int8), [0]])))
    found = []
    for start, stop in zip(edges[::2], edges[1::2]):
        if stop == window or inward[stop - 1] > end_zone:
            continue            # reaches beyond the end zone (or the run's middle): not at the end
        readings = near[start:stop][high[start:stop]]
        if readings.size < min_readings or inward[stop - 1] - inward[start] + profile.dx < min_length:
            continue
        if float(np.median(np.abs(readings - np.median(readings)))) * 1.4826 > max_spread:
            continue
        found.append((x.size - stop, x.size - start) if mirrored else (int(start), int(stop)))
    return sorted(found)


def find_reference_plates(profile: Profile, *, height: float = PLATE_HEIGHT, min_length: float = PLATE_MIN_LENGTH,
                          min_readings: int = PLATE_MIN_READINGS, max_spread: float = PLATE_MAX_SPREAD,
                          end_zone: float = PLATE_END_ZONE) -> tuple[float, float, list[str]]:
    """The road between the reference plates: (first kept position, last kept position, plates found).

    A plate is a stretch of readings more than ``height`` (m) above the road next to it, drop-outs
    inside it included, at least ``min_length`` (m) long, with at least ``min_readings`` such
    readings spread by at most ``max_spread`` (m) about their median, lying wholly (both edges)
    within ``end_zone`` (m) of the run's start or end and in that half of the run. The road next
    to it is the resistant line (:func:`road_line`) through the readings over
    :data:`PLATE_ROAD_LENGTH` (m) just inside the end zone, extended over the zone: a grade or a
    vertical curve lifts the road and the plate alike, so it is never taken for a plate. Everything
    from the run's end to the plate's inner edge is cut.
    """
    positive(height, "height", "m")
    x = profile.positions
    lo, hi, found = float(x[0]), float(x[-1]), []
    ends: tuple[Literal["start", "end"], ...] = ("start", "end")
    for end in ends:
        for start, stop in plates_at_one_end(profile, end, height=height, min_length=min_length,
                                             min_readings=min_readings, max_spread=max_spread, end_zone=end_zone):
            if end == "start":
                lo = max(lo, float(x[min(stop, x.size - 1)]))
            else:
                hi = min(hi, float(x[max(start - 1, 0)]))
            found.append(f"{end} ({format_number(float(x[start]))}..{format_number(float(x[stop - 1]))} m)")
    return lo, hi, found


def trim_reference_plates(profile: Profile, *, threshold: float = PLATE_HEIGHT, margin: float = 0.002,
                          name: str = "profile") -> Profile:
    """Cuts away reference plates at the ends; documented at :meth:`Profile.trim_reference_plates`."""
    margin_f = finite_number(margin, "margin")
    if margin_f < 0:
        raise InvalidInputError(f"margin must be >= 0 (m), got {margin!r}")
    lo, hi, found = find_reference_plates(profile, height=threshold)
    if not found:
        return profile.derive(profile.heights, step="trim_reference_plates(): plates none found, the profile is kept whole")
    x, z = profile.positions, profile.heights
    lo, hi = (lo + margin_f if lo > x[0] else lo), (hi - margin_f if hi < x[-1] else hi)
    first, stop = int(np.searchsorted(x, lo, "left")), int(np.searchsorted(x, hi, "right"))
    if stop - first < 2 or np.isnan(z[first:stop]).all():
        raise InvalidInputError(f"{name}: trimming reference plates leaves no road between {lo:.6g} m and {hi:.6g} m")
    keep = slice(first, stop)
    step = (f"trim_reference_plates(threshold={format_number(threshold)} m, margin={format_number(margin_f)} m): "
            f"plates at {' and '.join(found)}; kept {format_number(float(x[first]))}..{format_number(float(x[stop - 1]))} m")
    return profile.derive(z[keep], x[keep], step=step)


def remove_spikes(profile: Profile, alpha: float = 3.0) -> Profile:
    """Flags spikes as drop-outs (ISO 13473-1:2019 Annex E); documented at :meth:`Profile.remove_spikes`.

    Why two spike tests (this one and :func:`spike_mask`): this is the standard's own, a jump of
    alpha x dx between consecutive readings, which the MPD computes on its 0.5 mm grid
    (``mpd_spike_alpha``) so that MPD is ISO 13473-1's (and agrees with the captif-slp peer). On the
    file's own readings the same jump test means another thing at every sampling (at 0.0375 mm it
    flags any stone edge steeper than alpha), so the cleaning before the contact model uses
    :func:`spike_mask`, which judges a reading against the median of 0.5 mm around it whatever the
    sampling (``spike_alpha``)."""
    alpha_f = positive(alpha, "alpha", "a slope, no unit")
    z = profile.heights.copy()
    valid_index = np.flatnonzero(~np.isnan(z))
    jump = np.abs(np.diff(z[valid_index])) >= alpha_f * np.diff(profile.positions[valid_index])
    flagged = np.zeros(valid_index.size, dtype=bool)
    flagged[:-1] |= jump
    flagged[1:] |= jump
    z[valid_index[flagged]] = np.nan
    step = f"remove_spikes(alpha={format_number(alpha_f)}): {int(flagged.sum())} readings flagged as drop-outs"
    return profile.derive(z, step=step)


def fill_dropouts(profile: Profile) -> Profile:
    """Fills drop-outs by linear interpolation; documented at :meth:`Profile.fill_dropouts`."""
    z = profile.heights
    missing = np.isnan(z)
    if not missing.any():
        return profile.derive(z.copy(), step="fill_dropouts(): no drop-outs")
    if missing.all():
        raise InvalidInputError("every reading is a drop-out (or was removed as a spike): nothing to interpolate from; "
                                "are the heights in the unit the reader assumed?")
    filled = z.copy()
    filled[missing] = np.interp(profile.positions[missing], profile.positions[~missing], z[~missing])
    return profile.derive(filled, step=f"fill_dropouts(): {int(missing.sum())} readings interpolated linearly")


def resample(profile: Profile, dx: float) -> Profile:
    """Resamples to a uniform grid of spacing ``dx`` (m) by interval averaging; documented at :meth:`Profile.resample`."""
    new_dx = positive(dx, "dx")
    left = profile.positions[0] - 0.5 * profile.dx
    grid = profile.length / new_dx
    # checked before allocating: a dx a million times too fine (a unit slip) asked for terabytes
    if grid > MAX_RESAMPLE_FACTOR * profile.heights.size + 1:
        raise InvalidInputError(
            f"dx = {new_dx:g} m would resample {profile.heights.size} readings at {profile.dx:g} m to "
            f"{grid:.4g} samples, more than {MAX_RESAMPLE_FACTOR} per reading: interpolation adds points, "
            "not texture (is dx in the wrong unit? it is in metres)")
    n_bins = max(1, int(math.ceil(grid - 1e-9)))
    scaled = profile.positions - left
    scaled *= 1.0 / new_dx
    scaled += 1e-9
    bins = np.floor(scaled, out=scaled).astype(np.int64)
    np.clip(bins, 0, n_bins - 1, out=bins)
    if n_bins == bins.size and bins[0] == 0 and np.all(np.diff(bins) == 1):
        z = profile.heights.copy()  # one reading per interval: averaging changes nothing
        empty = int(np.count_nonzero(np.isnan(z)))
    else:
        valid = ~np.isnan(profile.heights)
        sums = np.bincount(bins[valid], weights=profile.heights[valid], minlength=n_bins)
        counts = np.bincount(bins[valid], minlength=n_bins)
        with np.errstate(invalid="ignore", divide="ignore"):
            z = sums / counts
        empty = int(np.count_nonzero(counts == 0))
    x = left + new_dx * (np.arange(n_bins) + 0.5)
    step = (f"resample(dx={format_number(new_dx)} m): {profile.heights.size} -> {n_bins} samples by interval averaging, "
            f"{empty} empty intervals")
    return profile.derive(z, x, new_dx, step=step)


def detrend(profile: Profile, kind: Literal["linear", "mean"] = "linear") -> Profile:
    """Removes the least-squares line or the mean of the valid readings; documented at :meth:`Profile.detrend`."""
    if kind not in ("linear", "mean"):
        raise InvalidInputError(f"kind must be 'linear' or 'mean', got {kind!r}")
    z, x = profile.heights, profile.positions
    valid = ~np.isnan(z)
    if kind == "mean":
        offset = float(np.mean(z[valid]))
        return profile.derive(z - offset, step=f"detrend(mean): removed {format_number(offset)} m")
    mean, slope, centred = line_fits(z[valid], x[valid])
    slope_f = float(slope[0])
    intercept = float(mean[0]) - slope_f * float(x[valid].mean())
    step = f"detrend(linear): removed slope {format_number(slope_f)} and offset {format_number(intercept)} m at x=0"
    return profile.derive(z - (slope_f * x + intercept), step=step)


def zero_phase_filter(profile: Profile, cutoff_wavelength: float, kind: Literal["low", "high"]) -> Profile:
    """A 2nd-order Butterworth section (bilinear transform, pre-warped to ``cutoff_wavelength``, m)
    run forwards and backwards (scipy.signal.sosfiltfilt, steady-state start), so zero phase and
    gain 1/2 at the cut-off, as ISO 13473-1:2019 Annex D asks.

    Ends: the low-pass extends the profile by its odd reflection of 9 samples (scipy's default, as
    captif-slp has it). The high-pass, whose settling length is three cut-off wavelengths (some
    500 mm), extends it that far by :func:`trend_and_mirror` (its local line carried on, the
    texture about it mirrored): with 9 odd samples it read the end baselines of a 1 mm cosine 30 %
    and 52 % deep (MPD +4.7 % on 2 m; now 0.2 %), and a 2 m piece of a graded synthetic road
    differed from the same stretch filtered within a longer run by up to 6.3 mm at its ends (median
    0.28 mm, 24 cases; now 0.51 mm and 0.04 mm). A longer odd reflection doubles the end's
    deviation from the local level; an even one kinks a grade. For the low-pass (15 samples at
    0.5 mm) the 9-sample reflection measured better on random texture."""
    from scipy import signal  # scipy on first use: the command line starts without it
    wavelength = positive(cutoff_wavelength, "cutoff_wavelength")
    require_grid(profile, f"{kind}pass")
    if wavelength <= 2.0 * profile.dx:
        raise InvalidInputError(f"cutoff_wavelength {wavelength:.3g} m must exceed twice dx ({2 * profile.dx:.3g} m)")
    if kind == "high" and wavelength > MAX_HIGHPASS_STEPS * profile.dx:
        # scipy's filter start-up solve is singular there (LinAlgError at 2e9 steps, found probing)
        raise InvalidInputError(f"cutoff_wavelength {wavelength:.3g} m is more than {MAX_HIGHPASS_STEPS:.0e} times dx "
                                f"({profile.dx:.3g} m): a high-pass that long is numerically singular, and on a "
                                f"{profile.length:.3g} m profile it removes no more than a line (detrend does that)")
    sections = signal.butter(2, 2.0 * profile.dx / wavelength, btype="lowpass" if kind == "low" else "highpass",
                             output="sos")
    if kind == "low":
        z = signal.sosfiltfilt(sections, profile.heights, padlen=min(9, profile.heights.size - 1))
    else:
        pad = min(int(np.ceil(3.0 * wavelength / profile.dx)), profile.heights.size - 1)
        extended = trend_and_mirror(profile.heights, pad)
        z = signal.sosfiltfilt(sections, extended, padtype=None)[pad:pad + profile.heights.size]
    return profile.derive(z, step=f"{kind}pass(cutoff_wavelength={format_number(wavelength)} m): 2nd-order Butterworth, zero phase")


def trend_and_mirror(heights: np.ndarray, pad: int) -> np.ndarray:
    """``heights`` with ``pad`` (< len) readings added at each end: the least-squares line of the
    end's first ``pad + 1`` readings carried on, plus the residuals about it mirrored about the end
    reading. A grade goes on straight (no kink for a high-pass to ring on) and the texture keeps its
    level (no jump), which neither an odd nor an even reflection does for both."""
    if pad < 1:
        return np.asarray(heights, dtype=np.float64)
    z = np.asarray(heights, dtype=np.float64)
    offsets = np.arange(pad + 1, dtype=np.float64)   # samples from the end, inwards

    def outward(end: np.ndarray) -> np.ndarray:
        """The pad readings beyond ``end[0]`` (``end`` runs inwards from it), nearest first."""
        mean, slope, centred = line_fits(end, offsets)
        line = mean[0] + slope[0] * centred
        beyond = mean[0] + slope[0] * (-offsets[1:] - offsets.mean())
        return beyond + (end[1:] - line[1:])

    before = outward(z[:pad + 1])[::-1]
    after = outward(z[::-1][:pad + 1])
    return np.concatenate([before, z, after])


def require_grid(profile: Profile, what: str) -> None:
    """Refuses a profile with drop-outs or uneven sampling for ``what``, saying which step fixes it."""
    if np.isnan(profile.heights).any():
        raise InvalidInputError(f"{what} needs a profile without drop-outs: call fill_dropouts() or conditioned() first")
    if not profile.is_uniform:
        raise InvalidInputError(f"{what} needs uniform sampling: call resample(dx) or conditioned() first")


#: Half-width (m) of the running median of the spike criterion: ISO 13473-1's 0.5 mm grid spacing.
SPIKE_WINDOW = 0.5e-3
#: A reading further than this many robust standard deviations (1.4826 x MAD) of the run's heights
#: from its median, and at least OUTLIER_MIN_DISTANCE (m) away, is a gross outlier (a drop-out code).
OUTLIER_SIGMAS = 12.0
OUTLIER_MIN_DISTANCE = 0.015
#: The bulk job warns (and records the warning) when more than these shares of a run's readings are
#: removed as spikes or were drop-outs, or more than this share of its length was trimmed. The
#: first two are ISO 13473-1's per-segment validity limits for MPD.
WARN_SPIKE_FRACTION = 0.05
WARN_DROPOUT_FRACTION = 0.10
WARN_TRIMMED_FRACTION = 0.25


@dataclass(frozen=True)
class CleaningSummary:
    """What cleaning removed from one run (lengths in m, shares 0..1 of the readings kept after trimming;
    rows missing from the file, :func:`missing_positions`, count as readings and drop-outs)."""

    raw_length: float
    trimmed_length: float
    plates: str
    spike_fraction: float
    outlier_fraction: float
    dropout_fraction: float
    warnings: tuple[str, ...]


def spike_mask(profile: Profile, alpha: float) -> np.ndarray:
    """Readings that are spikes by the sampling-independent criterion of this module (True = spike);
    why it is not ISO 13473-1's jump test: :func:`remove_spikes`."""
    from scipy import ndimage  # scipy on first use: the command line starts without it
    alpha_f = positive(alpha, "alpha", "a slope, no unit")
    z = profile.heights
    valid = ~np.isnan(z)
    # the window counts readings: raw files are near-uniform, so dx converts the 0.5 mm to a count
    half = max(1, int(round(SPIKE_WINDOW / profile.dx)))
    filled = z.copy()
    if not valid.all():
        filled[~valid] = np.interp(profile.positions[~valid], profile.positions[valid], z[valid])
    local = ndimage.median_filter(filled, size=2 * half + 1, mode="nearest")
    return valid & (np.abs(z - local) >= alpha_f * SPIKE_WINDOW)


def gross_outliers(heights: np.ndarray) -> np.ndarray:
    """Readings (m) far outside their row's own height range, True = outlier: drop-out codes such
    as -850 mm, further than :data:`OUTLIER_SIGMAS` robust standard deviations (and
    :data:`OUTLIER_MIN_DISTANCE`) from the row's median. Rows are along the last axis; NaN is
    never an outlier."""
    z = np.asarray(heights, dtype=np.float64)
    # A row with no valid reading has no median: judged against 0, its NaNs are never outliers.
    rows = np.where(np.isfinite(z).any(axis=-1, keepdims=True), z, 0.0)
    median = np.nanmedian(rows, axis=-1, keepdims=True)
    spread = 1.4826 * np.nanmedian(np.abs(rows - median), axis=-1, keepdims=True)
    limit = np.maximum(OUTLIER_SIGMAS * spread, OUTLIER_MIN_DISTANCE)
    with np.errstate(invalid="ignore"):
        return np.abs(z - median) > limit


def outlier_mask(run: Readings) -> np.ndarray:
    """Readings far outside the run's own height range (:func:`gross_outliers` over all its
    readings, a surface's too), True = outlier."""
    z = run.heights
    return gross_outliers(z.reshape(-1)).reshape(z.shape)


def flag_outliers_and_spikes(item: Cleanable, spike_alpha: float | None,
                             spikes_of: Callable[[Cleanable, float], np.ndarray],
                             window: str) -> tuple[Cleanable, dict[str, float]]:
    """Gross outliers (:func:`outlier_mask`), then spikes (``spikes_of``, judged without the
    outliers) of a profile or a surface flagged as drop-outs (NaN), with one history line
    (``window`` says how the spike median's window is described); returns the flagged item and
    the shares 0..1 of the readings: ``spike_fraction``, ``outlier_fraction``, ``dropout_fraction``
    (the file's own drop-outs)."""
    z = item.heights
    dropouts = int(np.count_nonzero(np.isnan(z)))
    outliers = outlier_mask(item)
    spikes = np.zeros(z.shape, dtype=bool)
    if spike_alpha is not None:
        spikes = spikes_of(item.derive(np.where(outliers, np.nan, z)), spike_alpha) & ~outliers
    removed = outliers | spikes
    flagged = item.derive(np.where(removed, np.nan, z) if removed.any() else z, step=(
        f"clean(spike_alpha={spike_alpha}): {int(outliers.sum())} gross outliers and {int(spikes.sum())} spikes "
        f"(median {window}{format_number(SPIKE_WINDOW * 1e3)} mm) flagged as drop-outs"))
    n = z.size
    return flagged, {"spike_fraction": float(spikes.sum()) / n, "outlier_fraction": float(outliers.sum()) / n,
                     "dropout_fraction": dropouts / n}


def removal_notes(summary: CleaningSummary) -> tuple[str, ...]:
    """What the cleaning removed beyond the documented shares (:data:`WARN_SPIKE_FRACTION`,
    :data:`WARN_DROPOUT_FRACTION`, :data:`WARN_TRIMMED_FRACTION`), one sentence each: the notes
    a run's ``conditioning_warnings`` records, for line profiles and surfaces alike."""
    notes = []
    if summary.spike_fraction + summary.outlier_fraction > WARN_SPIKE_FRACTION:
        notes.append(f"{100 * (summary.spike_fraction + summary.outlier_fraction):.1f} % of the readings removed as spikes "
                     f"or outliers (warned above {100 * WARN_SPIKE_FRACTION:g} %)")
    if summary.dropout_fraction > WARN_DROPOUT_FRACTION:
        notes.append(f"{100 * summary.dropout_fraction:.1f} % of the readings are drop-outs "
                     f"(warned above {100 * WARN_DROPOUT_FRACTION:g} %)")
    if summary.trimmed_length > WARN_TRIMMED_FRACTION * summary.raw_length:
        notes.append(f"{summary.trimmed_length:.3g} m of {summary.raw_length:.3g} m trimmed as reference plates "
                     f"(warned above {100 * WARN_TRIMMED_FRACTION:g} % of the length)")
    return tuple(notes)


def clean(profile: Profile, *, spike_alpha: float | None = 3.0, trim_plates: bool = True,
          name: str = "profile", warn: bool = True) -> tuple[Profile, CleaningSummary]:
    """Trims reference plates, then flags gross outliers and spikes as drop-outs (NaN).

    Returns the cleaned profile (same sampling; drop-outs not yet filled) and what was removed.
    Warns (:class:`~roadtex.errors.ConditioningWarning`; with ``warn=False`` the notes are only
    kept in the summary's ``warnings``) beyond the documented shares
    (:data:`WARN_SPIKE_FRACTION`, :data:`WARN_DROPOUT_FRACTION`, :data:`WARN_TRIMMED_FRACTION`).

    Raises:
        InvalidInputError: nothing is left between the plates (the message names ``name``).
    """
    raw_length = profile.length
    plates = "none"
    if trim_plates:
        before = len(profile)
        profile = trim_reference_plates(profile, name=name)
        plates = profile.history[-1].split("plates at ", 1)[1].split("; kept", 1)[0] if len(profile) != before else "none"
    profile, shares = flag_outliers_and_spikes(profile, spike_alpha, spike_mask, "over +-")
    # Rows missing from the file (gaps in the distances) are drop-outs of the grid too: counted so,
    # every share taken of the grid's readings, the file's and the missing ones.
    missing = missing_positions(profile.positions, profile.dx).size
    if missing:
        total = len(profile) + missing
        shares = {key: value * len(profile) / total for key, value in shares.items()}
        shares["dropout_fraction"] += missing / total
    summary = CleaningSummary(raw_length=raw_length, trimmed_length=raw_length - profile.length, plates=plates,
                              **shares, warnings=())
    notes = removal_notes(summary)
    for note in notes if warn else ():
        warnings.warn(f"{name}: {note}", ConditioningWarning, stacklevel=2)
    return profile, CleaningSummary(**{**summary.__dict__, "warnings": tuple(notes)})
