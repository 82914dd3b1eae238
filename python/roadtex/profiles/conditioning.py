"""Conditioning steps for a :class:`~roadtex.profiles.profile.Profile`, in ISO 13473-1's order:
reference plates trimmed, resampling, spikes, drop-outs, filters, detrending.

Each function returns a new profile and records one history line; :class:`Profile`'s methods of
the same names call them. Filters are scipy.signal's zero-phase Butterworth sections.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Literal

import numpy as np
from scipy import signal

from roadtex._checks import finite_number, positive
from roadtex.errors import InvalidInputError
from roadtex.profiles.trend import line_fits

if TYPE_CHECKING:
    from roadtex.profiles.profile import Profile


def format_number(value: float) -> str:
    """A number as history lines write it: six significant digits."""
    return f"{value:.6g}"


def trim_reference_plates(profile: Profile, *, threshold: float = 0.02, margin: float = 0.002) -> Profile:
    """Cuts away reference plates at the ends; documented at :meth:`Profile.trim_reference_plates`."""
    threshold_f = positive(threshold, "threshold")
    margin_f = finite_number(margin, "margin")
    if margin_f < 0:
        raise InvalidInputError(f"margin must be >= 0 (m), got {margin!r}")
    z, x = profile.heights, profile.positions
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
        raise InvalidInputError(f"trimming reference plates leaves no road between {lo:.6g} m and {hi:.6g} m")
    keep = slice(first, stop)
    where = " and ".join(found) if found else "none found"
    step = (f"trim_reference_plates(threshold={format_number(threshold_f)} m, margin={format_number(margin_f)} m): "
            f"plates at {where}; kept {format_number(float(x[first]))}..{format_number(float(x[stop - 1]))} m")
    return profile.derive(z[keep], x[keep], step=step)


def remove_spikes(profile: Profile, alpha: float = 3.0) -> Profile:
    """Flags spikes as drop-outs (ISO 13473-1:2019 Annex E); documented at :meth:`Profile.remove_spikes`."""
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
    filled = z.copy()
    filled[missing] = np.interp(profile.positions[missing], profile.positions[~missing], z[~missing])
    return profile.derive(filled, step=f"fill_dropouts(): {int(missing.sum())} readings interpolated linearly")


def resample(profile: Profile, dx: float) -> Profile:
    """Resamples to a uniform grid of spacing ``dx`` (m) by interval averaging; documented at :meth:`Profile.resample`."""
    new_dx = positive(dx, "dx")
    left = profile.positions[0] - 0.5 * profile.dx
    n_bins = max(1, int(math.ceil(profile.length / new_dx - 1e-9)))
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
    run forwards and backwards (scipy.signal.sosfiltfilt: odd extension of 9 samples, steady-state
    start), so zero phase and gain 1/2 at the cut-off, as ISO 13473-1:2019 Annex D asks."""
    wavelength = positive(cutoff_wavelength, "cutoff_wavelength")
    require_grid(profile, f"{kind}pass")
    if wavelength <= 2.0 * profile.dx:
        raise InvalidInputError(f"cutoff_wavelength {wavelength:.3g} m must exceed twice dx ({2 * profile.dx:.3g} m)")
    sections = signal.butter(2, 2.0 * profile.dx / wavelength, btype="lowpass" if kind == "low" else "highpass",
                             output="sos")
    z = signal.sosfiltfilt(sections, profile.heights, padlen=min(9, profile.heights.size - 1))
    return profile.derive(z, step=f"{kind}pass(cutoff_wavelength={format_number(wavelength)} m): 2nd-order Butterworth, zero phase")


def require_grid(profile: Profile, what: str) -> None:
    """Refuses a profile with drop-outs or uneven sampling for ``what``, saying which step fixes it."""
    if np.isnan(profile.heights).any():
        raise InvalidInputError(f"{what} needs a profile without drop-outs: call fill_dropouts() or conditioned() first")
    if not profile.is_uniform:
        raise InvalidInputError(f"{what} needs uniform sampling: call resample(dx) or conditioned() first")
