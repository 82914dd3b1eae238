"""Heights that cannot be a road texture in metres: the warning every function taking heights gives.

A texture profile written in millimetres (or micrometres) but passed as metres is the commonest
mistake with profile data; the numbers then look like a mountain range to the contact model and
the spectra. The check looks at each row with its least-squares line removed.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np

from roadtex.errors import CoarseSamplingWarning, ImplausibleTextureWarning
from roadtex.profiles.conditioning import OUTLIER_MIN_DISTANCE, gross_outliers
from roadtex.profiles.trend import remove_lines

PLAUSIBLE_PEAK_TO_VALLEY = 1.0
#: rms height (m), least-squares line removed, above which roadtex warns (same reason).
PLAUSIBLE_RMS = 0.25
#: Median |dz/dx| above which roadtex warns: half the profile steeper than 87 degrees. Road
#: texture has median slopes well under 1 (pore walls and chip edges are few); heights in mm on a
#: grid in m have slopes 1000 times the true ones, which also catches fine textures in mm.
PLAUSIBLE_MEDIAN_SLOPE = 20.0
#: Smallest rms height (m, line removed) of a measured road texture profile. Real surfaces, the
#: smoothest concrete included, have rms heights of some 0.05 mm and more; heights written in mm
#: but read as micrometres are 1000 times too small (0.05 to 3 um), below this floor.
PLAUSIBLE_MIN_RMS = 10e-6
#: Coarsest sampling interval (m) of a texture profile: texture profilometers sample at 1 mm or
#: finer (ISO 13473-1). Distances in mm read as metres make dx 1000 times too coarse (10 mm to 1 m).
PLAUSIBLE_MAX_DX = 5e-3

#: Longest wavelength of road texture (m): megatexture ends at 0.5 m (ISO 13473-1, ISO 13473-4).
TEXTURE_MAX_WAVELENGTH = 0.5

#: Metadata key a reader sets (to where the unit of the file's distances comes from, e.g. "m (OpenCRG)",
#: "mm (the file's header)", "mm (given for the file)") when that unit is certain: stated by the
#: format, the file's header or the caller, not assumed (a heights-only file's bare dx, a .npy's
#: default metres). Such a file is never taken for distances in mm read as m for its interval
#: alone: above PLAUSIBLE_MAX_DX it is processed, with a CoarseSamplingWarning.
DISTANCE_UNIT_STATED = "distance_unit_stated"

#: Rows longer than two of these (m) are judged stretch by stretch, each with its own line (or
#: median) removed: a long run's grades and vertical curves are road geometry, not texture, and
#: over a metre they stay far below the limits (a crest whose grade changes by 4 % over 200 m rises
#: 1 m above its chord: a correct profile of 200 m in metres would otherwise read as millimetres;
#: over 1 m it rises 0.1 mm).
JUDGED_STRETCH = 1.0

#: Fewest samples of a stretch: coarser grids (dx over 1 m / 100 = 10 mm: far too coarse for
#: texture, e.g. dx given in mm) are judged row by row.
MIN_STRETCH_POINTS = 100

#: Set inside :func:`judged_once` (for this thread or task only).
_JUDGED: ContextVar[bool] = ContextVar("roadtex_heights_judged", default=False)


@contextmanager
def judged_once() -> Iterator[None]:
    """Within the block, in this thread (or task) only, :func:`warn_if_implausible_texture` does
    nothing: for the bulk job, which judges each run's heights itself with
    :func:`implausible_texture` and refuses an implausible run. The functions it then calls on that
    run's data (the reader, the contact model, the spectra, the pilots' solves) would repeat the same
    judgement on the same heights, or on heights derived from them, at a fifth of the job's Python
    time. The job's own refusals are not affected: they call :func:`implausible_texture` directly.
    """
    token = _JUDGED.set(True)
    try:
        yield
    finally:
        _JUDGED.reset(token)


def stated_distance_unit(metadata: dict[str, object]) -> str | None:
    """Where the unit of a read file's distances comes from (:data:`DISTANCE_UNIT_STATED`), or None
    when it was assumed."""
    value = metadata.get(DISTANCE_UNIT_STATED)
    return value if isinstance(value, str) and value else None


def set_distance_unit(metadata: dict[str, object], stated: str | None) -> dict[str, object]:
    """``metadata`` (changed in place and returned) with :data:`DISTANCE_UNIT_STATED` set to
    ``stated``, or removed when None: a reader decides it for every file it reads, never keeping
    one from stored metadata (a sidecar's dx is a bare number, whatever an earlier read found)."""
    metadata.pop(DISTANCE_UNIT_STATED, None)
    if stated:
        metadata[DISTANCE_UNIT_STATED] = stated
    return metadata


def coarse_sampling(dx: float, name: str, stated: str | None = None) -> str | None:
    """What to tell the user about a file ``name`` sampled every ``dx`` (m) when that is above
    :data:`PLAUSIBLE_MAX_DX` and the file is processed all the same (its distance unit ``stated``,
    or the caller allowed it), or None when ``dx`` is within it."""
    if not (np.isfinite(dx) and dx > PLAUSIBLE_MAX_DX):
        return None
    unit = f"its distances' unit is {stated}, so" if stated else "its distances' unit is not stated, yet"
    # no texture wavelength resolved at all: a unit stated wrongly is likelier than such a survey
    none = (f" At that interval it resolves no texture wavelength (up to {TEXTURE_MAX_WAVELENGTH * 1e3:g} mm): "
            "were its distances in millimetres?") if 2.5 * dx > TEXTURE_MAX_WAVELENGTH else ""
    return (f"{name}: sampled every {dx * 1e3:.4g} mm, more coarsely than texture profilometers (1 mm or finer, "
            f"ISO 13473-1; roadtex's plausible limit is {PLAUSIBLE_MAX_DX * 1e3:g} mm); {unit} the interval is taken "
            "as read. Only the bands its sampling resolves are reported (wavelengths from 2.5 times its interval: "
            "the shorter bands' rows are marked not reported, with the reason); its MPD and contact measures "
            f"describe straight chords between readings that far apart.{none}")


def implausible_texture(heights: np.ndarray, dx: float, name: str, *, row: str = "segment",
                        measured: bool = True, skip_codes: bool | None = None,
                        interval_stated: bool = False) -> str | None:
    """Why ``heights`` (m; one row per ``row``: a segment, or a surface row along the road)
    cannot be a road texture profile in metres, or None.

    Looks at each row with its least-squares line removed (rows with NaN: their median), stretch by
    stretch in rows longer than two :data:`JUDGED_STRETCH` (a long run's grades and vertical curves
    are not texture); rows with NaN are judged on their valid readings' spread only. With
    ``skip_codes`` (default: ``measured``) drop-out codes, readings far outside the row's own range
    (:func:`~roadtex.profiles.conditioning.gross_outliers`), are left out: conditioning removes them
    from a file before anything else. Used by every function that takes heights (a warning) and by
    the bulk job (which refuses the run). With ``measured`` (a file read, the bulk job's runs) it
    also refuses heights too small for a road (rms below :data:`PLAUSIBLE_MIN_RMS`: mm read as um) and
    a sampling too coarse for texture (dx above :data:`PLAUSIBLE_MAX_DX`: distances in mm read as
    m), unless ``interval_stated`` (the file's distance unit is certain, :func:`stated_distance_unit`:
    a coarse interval is then the data's, see :func:`coarse_sampling`); the solvers and spectra,
    which also take model problems, check the upper limits only.
    """
    rows = np.atleast_2d(np.asarray(heights, dtype=np.float64))
    # In a file, drop-out codes (a -850 mm reading among mm of texture) say nothing about the
    # unit, and conditioning removes them before anything else: judged without them. Heights
    # handed to a solver are judged as they are (a code there is solved as a 850 mm pit).
    # (no row spanning more than the outliers' least distance holds a code: the medians are skipped)
    if (measured if skip_codes is None else skip_codes) and may_hold_codes(rows):
        codes = gross_outliers(rows)
        if codes.any():
            rows = np.where(codes, np.nan, rows)
    n = rows.shape[1]
    if rows.size == 0 or n < 2 or not (np.isfinite(dx) and dx > 0):
        return None
    # A row without two neighbouring readings says nothing: judged as flat and never flagged (so
    # that no NaN-only slice reaches numpy's nan-functions, whose warnings would need a
    # process-wide filter, which run threads must not touch).
    steps = np.diff(rows, axis=1)
    judgeable = ~np.all(np.isnan(steps), axis=1)
    if not judgeable.any():
        return None
    if not judgeable.all():
        rows = np.where(judgeable[:, None], rows, 0.0)
        steps = np.where(judgeable[:, None], steps, 0.0)
    with np.errstate(all="ignore"):
        slopes = np.abs(steps) / dx
        if np.isnan(rows).any():
            centred = by_stretches(rows, dx, less_medians)
            peak_to_valley = np.nanmax(centred, axis=1) - np.nanmin(centred, axis=1)
            rms = np.sqrt(np.nanmean(centred**2, axis=1))
        else:
            detrended = by_stretches(rows, dx, lambda block: remove_lines(block)[0])
            peak_to_valley = detrended.max(axis=1) - detrended.min(axis=1)
            rms = np.sqrt(np.mean(detrended**2, axis=1))
        steep = median_above(slopes, PLAUSIBLE_MEDIAN_SLOPE)
        large = (peak_to_valley > PLAUSIBLE_PEAK_TO_VALLEY) | (rms > PLAUSIBLE_RMS) | steep
        large &= judgeable
        small = (rms < PLAUSIBLE_MIN_RMS) & ~large & judgeable if measured else np.zeros_like(large)
    coarse = measured and not interval_stated and dx > PLAUSIBLE_MAX_DX
    bad = large | small | coarse
    if not bad.any():
        return None
    first = int(np.argmax(bad))
    with np.errstate(all="ignore"):   # the first bad row's median slope, for the message only
        median_slope = {first: float(np.nanmedian(slopes[first]))}
    length = int(round(JUDGED_STRETCH / dx))
    trend = ("linear trend removed" if length < MIN_STRETCH_POINTS or n < 2 * length
             else f"linear trend removed per {JUDGED_STRETCH:g} m stretch")
    where = f"{name} ({row} {first}, {int(bad.sum())} of {bad.size} {row}s)" if rows.shape[0] > 1 else name
    if coarse and not large[first]:
        return (f"{where}: a sampling interval of {dx:.3g} m is implausibly coarse for a road texture profile "
                f"(roadtex expects at most {PLAUSIBLE_MAX_DX:g} m; texture profilometers sample at 1 mm or finer). "
                "Distances must be in metres: were they given in millimetres?")
    if small[first]:
        return (f"{where}: rms height {rms[first]:.3g} m ({trend}) is implausibly small for a road "
                f"texture profile (roadtex expects at least {PLAUSIBLE_MIN_RMS:g} m). Heights must be in metres: "
                "were millimetres read as micrometres?")
    return (f"{where}: peak-to-valley {peak_to_valley[first]:.3g} m, rms {rms[first]:.3g} m ({trend}) "
            f"and median slope {median_slope[first]:.3g} are implausible for a road texture profile "
            f"(roadtex warns above {PLAUSIBLE_PEAK_TO_VALLEY:g} m, {PLAUSIBLE_RMS:g} m and {PLAUSIBLE_MEDIAN_SLOPE:g}). "
            "Heights and dx must be in metres: were the heights given in millimetres?")


def implausible_surface(heights: np.ndarray, dx: float, name: str, *, interval_stated: bool = False) -> str | None:
    """The bulk job's judgement of a surface run's heights (m, rows across the road), shared by
    ``roadtex manifest`` so that the two agree: every valid reading, drop-out codes aside (as
    conditioning removes them), judged as one row (:func:`implausible_texture`); "no valid
    reading" when none is left, else None when plausible."""
    z = np.asarray(heights, dtype=np.float64)
    codes = gross_outliers(z.reshape(-1)).reshape(z.shape)
    finite = z[np.isfinite(z) & ~codes]
    return (implausible_texture(finite[None, :], dx, name, interval_stated=interval_stated) if finite.size
            else "no valid reading")


#: The widest plausible surface (m): a lane is 3.5 to 4 m wide and texture scanners' swaths are
#: narrower. Rows spread wider than this are a spacing across in the wrong unit (dy = 1 for 1 mm).
PLAUSIBLE_MAX_WIDTH = 5.0
#: The finest plausible spacing across (m): 1 um, as the job's finest --dx (a header's 1e-9 m
#: increment would make rows 1 nm apart).
PLAUSIBLE_MIN_DY = 1e-6


def implausible_across(dy: float, rows: int, name: str, *, tile_length: float | None = None) -> str | None:
    """Why a surface's spacing across the road ``dy`` (m, between its ``rows`` rows) cannot be a
    road texture scan, or None. Coarse rows are not refused for being coarse (multi-laser arrays
    space their lines 10 to 100 mm apart; a certain unit is never second-guessed): only rows
    further apart than the longest texture wavelength (:data:`TEXTURE_MAX_WAVELENGTH`, 0.5 m) or
    than the areal model's tile (``tile_length``, m: its elements would be longer across than the
    tile along; a 1 m spacing on 1 mm readings ran past 100 s), a surface wider than
    :data:`PLAUSIBLE_MAX_WIDTH`, or rows finer than :data:`PLAUSIBLE_MIN_DY`: a dy in mm given as
    m, or a header's wrong increment."""
    if not (np.isfinite(dy) and dy > 0):
        return f"{name}: the spacing across the road dy = {dy!r} m is not a positive number"
    if dy < PLAUSIBLE_MIN_DY:
        return (f"{name}: its {rows} rows across the road are {dy:.4g} m apart, finer than {PLAUSIBLE_MIN_DY:g} m (1 um): "
                "not a road texture scan (a file's wrong increment across?)")
    width = rows * dy
    limits = [(TEXTURE_MAX_WAVELENGTH, "the longest texture wavelength")]
    if tile_length is not None:
        limits.append((tile_length, "the tile length (--segment-length)"))
    too_far = [f"{what} ({limit:g} m)" for limit, what in limits if dy > limit]
    if not too_far and width <= PLAUSIBLE_MAX_WIDTH:
        return None
    why = (f"further apart than {' and '.join(too_far)}" if too_far
           else f"{width:.4g} m wide in all, wider than a lane ({PLAUSIBLE_MAX_WIDTH:g} m)")
    return (f"{name}: its {rows} rows across the road are {dy:.4g} m apart, {why}: not a road texture scan "
            "(a dy in millimetres given as metres, or a file's wrong increment across?)")


def warn_if_implausible_across(dy: float, rows: int, name: str, *, stacklevel: int = 3) -> None:
    """Warns (ImplausibleTextureWarning) when :func:`implausible_across` refuses ``dy``; silent
    inside :func:`judged_once` (the bulk job judges it with the tile length and refuses the run)."""
    if _JUDGED.get():
        return
    reason = implausible_across(dy, rows, name)
    if reason is not None:
        warnings.warn(f"{reason} Computing as given.", ImplausibleTextureWarning, stacklevel=stacklevel)


def may_hold_codes(rows: np.ndarray) -> bool:
    """Whether any row of ``rows`` (m) spans more than :data:`OUTLIER_MIN_DISTANCE` (NaN aside):
    only then can :func:`~roadtex.profiles.conditioning.gross_outliers` find one (a reading is an
    outlier at least that far from its row's median), and its two medians per row are worth their
    cost (half of the judgement's time on 2 million points)."""
    with np.errstate(invalid="ignore"):
        span = np.fmax.reduce(rows, axis=1) - np.fmin.reduce(rows, axis=1)
    return bool(np.any(~(span <= OUTLIER_MIN_DISTANCE)))   # NaN (an empty row) or inf: let it judge


def median_above(values: np.ndarray, threshold: float) -> np.ndarray:
    """Per row, whether the median of the row's valid (non-NaN) ``values`` exceeds ``threshold``,
    exactly as ``np.nanmedian(values, axis=1) > threshold``, by counting instead of sorting (a
    tenth of the time): with m valid values of which c exceed the threshold, the median exceeds
    it when c >= m // 2 + 1, and not when c < (m + 1) // 2; only an even m with c = m / 2 (the
    two middle values on either side) needs the median itself. Rows need at least one valid value."""
    valid = np.count_nonzero(~np.isnan(values), axis=1)
    above = np.count_nonzero(values > threshold, axis=1)
    result = above >= valid // 2 + 1
    tied = (valid % 2 == 0) & (above == valid // 2)
    if tied.any():
        result[tied] = np.nanmedian(values[tied], axis=1) > threshold
    return result


def by_stretches(rows: np.ndarray, dx: float, detrend: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """``detrend`` (rows in, rows out) applied to each row of ``rows`` (heights, m) whole, or, for
    rows longer than two :data:`JUDGED_STRETCH`, to each stretch of it: stretches of equal length,
    the last one taking the remainder."""
    n = rows.shape[1]
    length = int(round(JUDGED_STRETCH / dx)) if dx > 0 else 0
    stretches = n // length if length else 0
    # A stretch of a few samples would fit its texture away: with dx itself in mm (0.5 for
    # 0.5 mm), a metre is 2 samples and every line through them leaves zero. Such rows, and any
    # whose stretches hold fewer than MIN_STRETCH_POINTS, are judged whole.
    if stretches < 2 or length < MIN_STRETCH_POINTS:
        return detrend(rows)
    head = (stretches - 1) * length   # equal stretches, then the last with the remainder
    body = detrend(rows[:, :head].reshape(-1, length)).reshape(rows.shape[0], head)
    return np.concatenate([body, detrend(rows[:, head:])], axis=1)


def less_medians(rows: np.ndarray) -> np.ndarray:
    """Each row less its median, ignoring NaN; a row of NaN only stays NaN (and never reaches
    numpy's nan-functions, whose all-NaN warnings would need a process-wide filter)."""
    centred = np.full_like(rows, np.nan)
    valid = ~np.all(np.isnan(rows), axis=1)
    centred[valid] = rows[valid] - np.nanmedian(rows[valid], axis=1, keepdims=True)
    return centred


def warn_if_implausible_texture(heights: np.ndarray, dx: float, name: str, *, stacklevel: int = 3,
                                row: str = "segment", measured: bool = False,
                                skip_codes: bool | None = None, stated: str | None = None) -> None:
    """Warns (ImplausibleTextureWarning) when any row of ``heights`` (m) cannot be a road profile
    (see :func:`implausible_texture`; ``row`` names what a row is; ``measured`` for a file read;
    ``skip_codes`` to leave drop-out codes out; ``stated``: where the file's distance unit comes
    from, None when assumed); the computation goes on as given. A file read (``measured``) whose
    unit is ``stated`` and whose interval alone is above :data:`PLAUSIBLE_MAX_DX` gets a
    :class:`~roadtex.errors.CoarseSamplingWarning` instead (:func:`coarse_sampling`). Silent inside
    :func:`judged_once`."""
    if _JUDGED.get():
        return
    reason = implausible_texture(heights, dx, name, row=row, measured=measured, skip_codes=skip_codes,
                                 interval_stated=stated is not None)
    if reason is not None:
        warnings.warn(f"{reason} Computing as given.", ImplausibleTextureWarning, stacklevel=stacklevel)
    elif measured and stated is not None and (note := coarse_sampling(dx, name, stated)) is not None:
        warnings.warn(note, CoarseSamplingWarning, stacklevel=stacklevel)
