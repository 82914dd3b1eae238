"""Texture and contact-pressure spectra in octave and one-third-octave wavelength bands.

The analysis follows the DFT method of ISO 13473-4 (narrow-band spectrum by the discrete Fourier
transform, then summed into constant-percentage bands). Units are SI: heights and wavelengths in
metres, pressures in pascals, frequencies in hertz; only vehicle speed is in km/h, as acousticians
quote it.

**Bands.** Band ``n`` has the exact centre wavelength 10^(-n/10) m (= 1000 / 10^(n/10) mm) and edges
at 10^(-(n +- 1/2)/10) m; an octave band ``n`` (n a multiple of 3) spans the third-octave bands n-1,
n and n+1, so its edges are 10^(-(n +- 3/2)/10) m. The candidate bands are those of ISO 13473-4:
third octaves 500 mm (n = 3) to 0.4 mm (n = 34) and octaves 500 mm (n = 3) to 0.5 mm (n = 33).
Labels are the nominal values acousticians write, in millimetres ("500", "31.5", "8", "3.15", "0.63").

**Band powers.** A profile of N points at spacing dx has the evaluation length L = N dx and DFT lines
at spatial frequencies k / L, k = 1 .. N/2 (cycles per metre). Each line belongs wholly to the band
whose edges bracket its frequency (a line exactly on an edge goes to the band of shorter wavelength).
The band's mean square is the sum of its lines' one-sided powers, so band powers add up to the
signal's variance over the covered bands (Parseval) and an octave is exactly the sum of its three
third octaves. The level is L = 10 lg(mean square / reference^2) = 20 lg(rms / reference) dB.

**Measured (non-periodic) profiles**, ``periodic=False``, the default for texture: the least-squares
line is removed (offset and slope suppression, ``detrend="linear"``; ``"mean"`` removes the offset
only) and a periodic Hann window is applied, with the power divided by the window's mean square so
that band powers keep the signal's variance (energy-corrected). A sine whose wavelength divides L
then spreads over three lines whose powers add to A^2 / 2 exactly; other sines leak a little into
neighbouring lines, as with any window.

**Periodic signals**, ``periodic=True``, the default for contact pressure: the output of the periodic
contact model (enveloped profile, pressure) repeats with period L exactly, so the DFT lines are its
exact Fourier series: no window, no detrending (the mean is the k = 0 line, which no band holds) and
no leakage. Band powers are then exact. To compare a segment with its envelope, analyse the segment
with ``periodic=True`` as well: that is how the model saw it.

**Which bands are reported.** A band is flagged ``reported`` only where two limits allow it:

- sampling: its centre wavelength is at least ``MIN_POINTS_PER_WAVELENGTH`` (2.5) sampling
  intervals, which keeps the whole band below the Nyquist wavenumber (lower edge >= 2.23 dx);
- evaluation length: L is at least ``MIN_WAVELENGTHS_PER_LENGTH`` (12) centre wavelengths, which
  puts at least two DFT lines in a third octave (0.23 L / lambda_c line spacings wide: 2.77 at
  the limit, so two or three lines; three or more from about 13 wavelengths up).

An octave is reported when its three third octaves are.

**The filter method**, ``method="filter"`` (the normative method of ISO 13473-4:2024): a bank of IEC
61260-1 class-1 band-pass filters run along the profile, with octave-wise decimation for the long
bands; see :mod:`roadtex.spectra.filters` for the design, the settling and the periodic case. Measured
profiles lose each band's settling length (10 to 13.5 centre wavelengths for third octaves), so a
band is reported only when 12 centre wavelengths are left after it. These are the limits of ISO 13473-4:2024
(sampling: centre wavelength >= 2.5 dx; evaluation length >= 12 centre wavelengths) as quoted by a
public implementation of that edition; the standard's text itself was not at hand, so both are
module constants and ``band_table`` arguments. Levels are computed for every band that holds at
least one DFT line whether reported or not (filter on ``reported``); a band that holds no line gets
NaN (with either method), and a band whose lines carry no power gets -inf dB. So does a band whose
power lies more than 240 dB below the signal's own mean square (its mean included:
:data:`ROUNDING_SHARE`): double precision cannot carry such a band, so what it holds is rounding
(a constant signal's bands, a uniform pressure's), not a level.
"""


from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Sequence

import numpy as np
import polars as pl

from roadtex._checks import positive, spacing_of
from roadtex.errors import InvalidInputError
from roadtex.profiles.plausibility import warn_if_implausible_texture
from roadtex.profiles.profile import Profile
from roadtex.profiles.trend import remove_lines
from roadtex.spectra.bands import (
    BLOCK_VALUES,
    MIN_WAVELENGTHS_PER_LENGTH,
    REFERENCE_PRESSURE,
    REFERENCE_TEXTURE,
    BandKind,
    Detrend,
    Window,
    band_table,
    check_band_kind,
    check_signals,
    line_bands,
    window_and_detrend,
)
from roadtex.spectra.filters import filter_bank, filtered_mean_squares

Method = Literal["dft", "filter"]

# --------------------------------------------------------------------------------------------------
# Band levels
# --------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class BandLevels:
    """Band levels of many signals, from :func:`band_levels`.

    Attributes:
        bands: the :func:`band_table` of every candidate band, one row per column of ``levels``;
            filter on its ``reported`` column to keep the bands the standard's limits allow.
        mean_square: (n_signals, n_bands) band mean squares, in the signal's unit squared (m^2, Pa^2);
            NaN where the band holds no DFT line.
        levels: (n_signals, n_bands) levels 10 lg(mean_square / reference^2) in dB; -inf where the band's
            lines carry no power, NaN where the band holds no line.
        reference: the reference (m or Pa).
        dx: sampling interval (m).
        periodic: whether the signals were analysed as periodic (no window, no detrending).
        method: "dft" or "filter".
    """

    bands: pl.DataFrame
    mean_square: np.ndarray
    levels: np.ndarray
    reference: float
    dx: float
    periodic: bool
    method: Method = "dft"

    def to_frame(self, *, reported_only: bool = False) -> pl.DataFrame:
        """Long format: one row per (signal, band) with the band columns, ``mean_square`` and ``level_db``.

        ``signal`` is the row index of the input array.
        """
        n_signals, n_bands = self.levels.shape
        frame = pl.concat([self.bands] * n_signals).with_columns(
            pl.Series("signal", np.repeat(np.arange(n_signals, dtype=np.int64), n_bands)),
            pl.Series("mean_square", self.mean_square.reshape(-1)),
            pl.Series("level_db", self.levels.reshape(-1)),
        ).select("signal", *self.bands.columns, "mean_square", "level_db")
        return frame.filter(pl.col("reported")) if reported_only else frame


#: A band's rms at most this share of the signal's own rms (its mean included) is rounding, not
#: signal (-inf dB): the transforms carry about 1e-16 of the signal's magnitude, and no band of a
#: measured texture or solved pressure lies 240 dB below its signal.
ROUNDING_SHARE = 1e-12


def own_mean_squares(signals: np.ndarray) -> np.ndarray:
    """Each row's mean square, its mean included (rows,), without a temporary of the rows' size."""
    return np.einsum("ij,ij->i", signals, signals) / signals.shape[1]


def without_rounding(mean_square: np.ndarray, own: np.ndarray) -> np.ndarray:
    """Band mean squares (rows, bands) with those of rounding (:data:`ROUNDING_SHARE` of each row's
    own mean square ``own``, :func:`own_mean_squares` of the signals as given) set to 0 (-inf dB);
    NaN (no line) kept."""
    return np.where(mean_square <= ROUNDING_SHARE**2 * own[:, None], 0.0, mean_square)


def band_levels(values: Profile | np.ndarray | Sequence[Sequence[float]], dx: float | None = None, *, kind: BandKind = "third_octave",
                reference: float = REFERENCE_TEXTURE, periodic: bool = False, window: Window | None = None,
                detrend: Detrend | None = None, method: Method = "dft") -> BandLevels:
    """Band levels of many signals at once (vectorised: by blocks of rows; DFT then band sums, or a
    filter bank).

    Args:
        values: 2-D array, one signal (profile heights in m, or pressures in Pa) per row, N >= 8 points;
            or a :class:`~roadtex.Profile` (one signal, equally spaced, no drop-outs), which carries its dx.
        dx: sampling interval (m); required with an array (with a Profile it may be left out; given,
            it must be the Profile's).
        kind: "third_octave" or "octave".
        reference: level reference in the signal's unit (default 1e-6 m, for texture).
        periodic: True for signals that repeat with period N dx (periodic contact-model output): exact
            DFT, no window, no detrending. False (default) for measured profiles: detrend, then window.
        window: "hann" (default when ``periodic=False``) or "rectangular"; only for ``periodic=False``.
        detrend: "linear" (default when ``periodic=False``, offset and slope suppression) or "mean";
            only for ``periodic=False``.
        method: "dft" (default; the narrow-band spectrum summed into bands) or "filter" (class-1 band-pass
            filters run along the signal, :mod:`roadtex.spectra.filters`; no window, so ``window`` must
            stay unset; ``reported`` then also needs 12 centre wavelengths left after settling).

    Returns:
        A :class:`BandLevels` with every candidate band and its ``reported`` flag.

    Raises:
        ValueError: not 2-D, fewer than 8 points, NaN or inf, non-positive dx or reference, unknown kind,
            window, detrend or method, window/detrend given with ``periodic=True``, or a window with
            ``method="filter"``.

    Warns:
        ImplausibleTextureWarning: with the texture reference (1 um), heights that cannot be a road
            texture in metres (given in mm?).
    """
    kind = check_band_kind(kind)
    if method not in ("dft", "filter"):
        raise InvalidInputError(f"method must be 'dft' or 'filter', got {method!r}")
    if method == "filter" and window is not None:
        raise InvalidInputError("window applies only to method='dft': the filter method runs the band filters "
                                "along the whole signal, unwindowed")
    given, dx_given, _ = spacing_of(values, dx, "values")
    if given is not values:   # a Profile: one signal
        given = np.asarray(given, dtype=np.float64)[None, :]
    signals = check_signals(given, "values", 2)
    dx = positive(dx_given, "dx", "metres")
    reference = positive(reference, "reference", "the signal's unit")
    window, detrend = window_and_detrend(bool(periodic), window, detrend)
    if reference == REFERENCE_TEXTURE:  # texture in metres: catch heights given in mm
        warn_if_implausible_texture(signals, dx, "values")
    if method == "filter":
        return _filter_levels(signals, dx, kind, reference, bool(periodic), detrend)
    n_signals, n_points = signals.shape
    table = band_table(dx, n_points * dx, kind)
    bands = table["band"].to_numpy()

    # One-sided line powers: 2 |Z_k|^2 / N^2, except the Nyquist line (k = N/2, N even), counted once.
    line_weight = np.full(n_points // 2, 2.0)
    if n_points % 2 == 0:
        line_weight[-1] = 1.0
    if window == "hann":
        taper = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(n_points) / n_points)  # periodic Hann
        line_weight /= np.mean(taper**2)  # energy correction: band powers keep the variance
    line_weight /= float(n_points) ** 2
    # Lines are in frequency order, so each band holds one contiguous slice of them: a plain sum
    # per slice (no cumulative sums, which would cancel for bands far below the total power, and
    # no matrix product, whose BLAS threads would compete with the contact solver's).
    line_band = line_bands(n_points, dx, kind)
    first_line = np.searchsorted(line_band, bands, side="left")
    end_line = np.searchsorted(line_band, bands, side="right")
    filled = end_line > first_line
    # The lines past the table's shortest band (0.4 mm) belong to no band: not turned into powers.
    # A model grid k times finer than the data has k times the lines (at 0.125 mm, 591 of a 0.5 m
    # segment's 2,000 are past it): 160 such rows took 5.3 to 6.5 ms against 10.2 to 12.4 ms. The
    # sums are the same slices of the same lines, the same bits.
    lines = int(end_line[filled].max()) if filled.any() else 0
    line_weight = line_weight[:lines]

    mean_square = np.empty((n_signals, bands.size))
    rows_per_block = max(1, BLOCK_VALUES // n_points)
    for start in range(0, n_signals, rows_per_block):
        block = signals[start:start + rows_per_block]
        if detrend is not None:
            block, _ = remove_lines(block, kind=detrend)
        if window == "hann":
            block = block * taper
        spectrum = np.fft.rfft(block, axis=1)[:, 1:lines + 1]
        power = (spectrum.real**2 + spectrum.imag**2) * line_weight
        sums = np.zeros((power.shape[0], bands.size))
        if filled.any():
            sums[:, filled] = np.add.reduceat(power, first_line[filled], axis=1)
            # reduceat runs each slice to the next start: trim the last filled band to its own end.
            last = np.flatnonzero(filled)[-1]
            sums[:, last] = power[:, first_line[last]:end_line[last]].sum(axis=1)
        mean_square[start:start + rows_per_block] = sums

    mean_square = without_rounding(mean_square, own_mean_squares(signals))
    mean_square[:, table["lines"].to_numpy() == 0] = np.nan
    with np.errstate(divide="ignore"):
        levels = 10.0 * np.log10(mean_square / reference**2)
    return BandLevels(table, mean_square, levels, reference, dx, bool(periodic))


def _filter_levels(signals: np.ndarray, dx: float, kind: BandKind, reference: float, periodic: bool,
                   detrend: Detrend | None) -> BandLevels:
    """band_levels(method="filter"): the filter bank by blocks of rows, and the settling-aware table."""
    n_signals, n_points = signals.shape
    table = band_table(dx, n_points * dx, kind)
    bank = filter_bank(dx, kind)
    mean_square = np.empty((n_signals, table.height))
    measured = np.zeros(table.height)
    # Blocks of rows bound memory, as for the DFT; the periodic run-in adds a few hundred samples.
    rows_per_block = max(1, BLOCK_VALUES // (4 * n_points))
    for start in range(0, n_signals, rows_per_block):
        block = signals[start:start + rows_per_block]
        if detrend is not None:
            block, _ = remove_lines(block, kind=detrend)
        mean_square[start:start + rows_per_block], measured = filtered_mean_squares(block, bank, periodic)
    if not periodic:
        table = _settled_table(table, measured, kind)
    # A band that holds no DFT line of the segment has no level, as with the DFT method: the filter
    # would only return its skirts' share of the neighbouring bands.
    mean_square = without_rounding(mean_square, own_mean_squares(signals))
    mean_square[:, table["lines"].to_numpy() == 0] = np.nan
    with np.errstate(divide="ignore"):
        levels = 10.0 * np.log10(mean_square / reference**2)
    return BandLevels(table, mean_square, levels, reference, dx, periodic, "filter")


def _settled_table(table: pl.DataFrame, measured: np.ndarray, kind: BandKind) -> pl.DataFrame:
    """The band table with the evaluation-length limit applied to the length left after settling."""
    bands = table["band"].to_numpy()
    longest = 10.0 ** (-(bands - (0.0 if kind == "third_octave" else 1.0)) / 10.0)
    required = MIN_WAVELENGTHS_PER_LENGTH * longest
    short = measured < required * (1.0 - 1e-9)
    name = "centre wavelength" if kind == "third_octave" else "centre wavelength of its longest third octave"
    reasons = []
    for why, too_short, left, need in zip(table["reason"].to_list(), short, measured, required):
        if too_short:
            extra = (f"length left after filter settling, {left * 1e3:.4g} mm, is under "
                     f"{MIN_WAVELENGTHS_PER_LENGTH:g} times the {name} ({need * 1e3:.4g} mm)")
            why = extra if why is None else f"{why}; {extra}"
        reasons.append(why)
    return table.with_columns(
        (pl.col("reported") & pl.Series(~short)).alias("reported"),
        pl.Series("reason", reasons, dtype=pl.String),
    )


def _levels_frame(values: object, dx: float | None, name: str, kind: BandKind, reference: float, periodic: bool,
                  window: Window | None, detrend: Detrend | None, method: Method) -> pl.DataFrame:
    values, dx, _ = spacing_of(values, dx, name)
    signal = check_signals(values, name, 1)
    result = band_levels(signal[None, :], dx, kind=kind, reference=reference, periodic=periodic,
                         window=window, detrend=detrend, method=method)
    return result.bands.with_columns(pl.Series("mean_square", result.mean_square[0]),
                                     pl.Series("level_db", result.levels[0]))


def third_octave_levels(heights: Profile | np.ndarray | Sequence[float], dx: float | None = None, *, reference: float = REFERENCE_TEXTURE,
                        periodic: bool = False, window: Window | None = None,
                        detrend: Detrend | None = None, method: Method = "dft") -> pl.DataFrame:
    """One-third-octave texture spectrum of one profile (ISO 13473-4, DFT or filter method).

    Args:
        heights: profile heights (m), N >= 8 points, no NaN (interpolate drop-outs first); or a
            :class:`~roadtex.Profile` (equally spaced, no drop-outs), which carries its dx.
        dx: sampling interval (m); required with an array (with a Profile it may be left out;
            given, it must be the Profile's).
        reference: level reference (m), default 1e-6 m.
        periodic: False (default) for a measured profile: linear detrend and Hann window. True for a
            periodic signal such as the enveloped profile of the periodic contact model: exact DFT.
        window, detrend: see :func:`band_levels` (``periodic=False`` only).
        method: "dft" (default) or "filter" (class-1 band filters); see :func:`band_levels`.

    Returns:
        The :func:`band_table` columns plus ``mean_square`` (m^2) and ``level_db``
        (20 lg(a_rms / reference)), one row per band from 500 mm to 0.4 mm.
    """
    return _levels_frame(heights, dx, "heights", "third_octave", reference, periodic, window, detrend, method)


def octave_levels(heights: Profile | np.ndarray | Sequence[float], dx: float | None = None, *, reference: float = REFERENCE_TEXTURE,
                  periodic: bool = False, window: Window | None = None,
                  detrend: Detrend | None = None, method: Method = "dft") -> pl.DataFrame:
    """Octave-band texture spectrum of one profile, 500 mm to 0.5 mm; as :func:`third_octave_levels`.

    With the DFT method each octave's mean square is exactly the sum of its three third octaves'; with
    ``method="filter"`` the octave has its own class-1 octave filter and the sum holds approximately
    (the filters' skirts differ; see docs/guide/spectra.md).
    """
    return _levels_frame(heights, dx, "heights", "octave", reference, periodic, window, detrend, method)


def pressure_levels(pressure: np.ndarray | Sequence[float], dx: float, *, reference: float = REFERENCE_PRESSURE,
                    kind: BandKind = "third_octave", periodic: bool = True, window: Window | None = None,
                    detrend: Detrend | None = None, method: Method = "dft") -> pl.DataFrame:
    """Band spectrum of a contact pressure distribution p(x) (Pa), e.g. ``roadtex.contact(...).pressure``.

    The level is 20 lg(p_rms / reference) with reference 1 Pa by default (``REFERENCE_PRESSURE``); the
    mean pressure is the k = 0 line and is in no band. ``periodic=True`` by default because the periodic
    contact model's pressure repeats with period N dx; pass ``periodic=False`` for the finite model.
    ``method``: "dft" (default) or "filter", as for :func:`band_levels`.

    Returns:
        The :func:`band_table` columns plus ``mean_square`` (Pa^2) and ``level_db``.
    """
    return _levels_frame(pressure, dx, "pressure", check_band_kind(kind), reference, periodic, window, detrend,
                         method)

