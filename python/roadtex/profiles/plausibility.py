"""Heights that cannot be a road texture in metres: the warning every function taking heights gives.

A texture profile written in millimetres (or micrometres) but passed as metres is the commonest
mistake with profile data; the numbers then look like a mountain range to the contact model and
the spectra. The check looks at each row with its least-squares line removed.
"""

from __future__ import annotations

import warnings

import numpy as np

from roadtex.errors import ImplausibleTextureWarning
from roadtex.profiles.trend import remove_lines

PLAUSIBLE_PEAK_TO_VALLEY = 1.0
#: rms height (m), least-squares line removed, above which roadtex warns (same reason).
PLAUSIBLE_RMS = 0.25
#: Median |dz/dx| above which roadtex warns: half the profile steeper than 87 degrees. Road
#: texture has median slopes well under 1 (pore walls and chip edges are few); heights in mm on a
#: grid in m have slopes 1000 times the true ones, which also catches fine textures in mm.
PLAUSIBLE_MEDIAN_SLOPE = 20.0


def implausible_texture(heights: np.ndarray, dx: float, name: str, *, row: str = "segment") -> str | None:
    """Why ``heights`` (m; one row per ``row``: a segment, or a surface row along the road)
    cannot be a road texture profile in metres, or None.

    Looks at each row with its least-squares line removed; rows with NaN are judged on their valid
    readings' spread only. Used by every function that takes heights (a warning) and by the bulk
    job (which refuses the run).
    """
    rows = np.atleast_2d(np.asarray(heights, dtype=np.float64))
    n = rows.shape[1]
    if rows.size == 0 or n < 2 or not (np.isfinite(dx) and dx > 0):
        return None
    with np.errstate(all="ignore"):
        if np.isnan(rows).any():
            centred = rows - np.nanmedian(rows, axis=1, keepdims=True)
            peak_to_valley = np.nanmax(centred, axis=1) - np.nanmin(centred, axis=1)
            rms = np.sqrt(np.nanmean(centred**2, axis=1))
            median_slope = np.nanmedian(np.abs(np.diff(rows, axis=1)), axis=1) / dx
        else:
            detrended, _ = remove_lines(rows)
            peak_to_valley = detrended.max(axis=1) - detrended.min(axis=1)
            rms = np.sqrt(np.mean(detrended**2, axis=1))
            median_slope = np.median(np.abs(np.diff(rows, axis=1)), axis=1) / dx
        bad = ((peak_to_valley > PLAUSIBLE_PEAK_TO_VALLEY) | (rms > PLAUSIBLE_RMS)
               | (median_slope > PLAUSIBLE_MEDIAN_SLOPE))
    if not bad.any():
        return None
    first = int(np.argmax(bad))
    where = f"{name} ({row} {first}, {int(bad.sum())} of {bad.size} {row}s)" if rows.shape[0] > 1 else name
    return (f"{where}: peak-to-valley {peak_to_valley[first]:.3g} m, rms {rms[first]:.3g} m (linear trend removed) "
            f"and median slope {median_slope[first]:.3g} are implausible for a road texture profile "
            f"(roadtex warns above {PLAUSIBLE_PEAK_TO_VALLEY:g} m, {PLAUSIBLE_RMS:g} m and {PLAUSIBLE_MEDIAN_SLOPE:g}). "
            "Heights and dx must be in metres: were the heights given in millimetres?")


def warn_if_implausible_texture(heights: np.ndarray, dx: float, name: str, *, stacklevel: int = 3,
                                row: str = "segment") -> None:
    """Warns (ImplausibleTextureWarning) when any row of ``heights`` (m) cannot be a road profile
    (see :func:`implausible_texture`; ``row`` names what a row is); the computation goes on as given."""
    reason = implausible_texture(heights, dx, name, row=row)
    if reason is not None:
        warnings.warn(f"{reason} Computing as given.", ImplausibleTextureWarning, stacklevel=stacklevel)
