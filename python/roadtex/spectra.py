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
  puts at least three DFT lines in the band.

An octave is reported when its three third octaves are. These are the limits of ISO 13473-4:2024
(sampling: centre wavelength >= 2.5 dx; evaluation length >= 12 centre wavelengths) as quoted by a
public implementation of that edition; the standard's text itself was not at hand, so both are
module constants and ``band_table`` arguments. Levels are computed for every band that holds at
least one DFT line whether reported or not (filter on ``reported``); a band that holds no line gets
NaN, and a band whose lines carry no power gets -inf dB.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Sequence

import numpy as np
import polars as pl

from roadtex._checks import as_float_array, positive

REFERENCE_TEXTURE = 1e-6
"""Reference texture amplitude, 1 um = 1e-6 m (ISO 13473-4): L_tx = 20 lg(a_rms / 1e-6 m)."""

REFERENCE_PRESSURE = 1.0
"""Reference contact pressure, 1 Pa: L_p = 20 lg(p_rms / 1 Pa). A choice: the seed's reference was not
available. Under 0.2 MPa mean pressure, band levels of the pressure fluctuation land near 80-110 dB."""

MIN_POINTS_PER_WAVELENGTH = 2.5
"""Sampling limit: a band is reported when its centre wavelength is >= 2.5 dx."""

MIN_WAVELENGTHS_PER_LENGTH = 12.0
"""Evaluation-length limit: a band is reported when N dx >= 12 centre wavelengths."""

MIN_POINTS = 8
"""Fewest points accepted in a profile, as for the contact solver."""

BandKind = Literal["third_octave", "octave"]
Window = Literal["hann", "rectangular"]
Detrend = Literal["linear", "mean"]

THIRD_OCTAVE_BANDS = tuple(range(3, 35))
"""Third-octave band indices n of ISO 13473-4: 500 mm (n = 3) to 0.4 mm (n = 34)."""

OCTAVE_BANDS = tuple(range(3, 34, 3))
"""Octave band indices n: 500 mm (n = 3) to 0.5 mm (n = 33)."""

# Nominal (R10) mantissas of the third-octave series, for n mod 10 = 0 .. 9.
_R10 = (10.0, 8.0, 6.3, 5.0, 4.0, 3.15, 2.5, 2.0, 1.6, 1.25)

BAND_COLUMNS = ("band", "label", "nominal_wavelength", "centre_wavelength", "lower_wavelength",
                "upper_wavelength", "lines", "reported", "reason")
"""Columns of :func:`band_table`, in order."""

FREQUENCY_COLUMNS = ("speed_kmh", "centre_frequency", "lower_frequency", "upper_frequency")
"""Columns added by :func:`with_time_frequency`."""

# Rows per FFT block in band_levels: about 4 million values (32 MB) per block bounds memory.
_BLOCK_VALUES = 1 << 22


# --------------------------------------------------------------------------------------------------
# Input checks
# --------------------------------------------------------------------------------------------------


def _check_kind(kind: object) -> BandKind:
    if kind not in ("third_octave", "octave"):
        raise ValueError(f"kind must be 'third_octave' or 'octave', got {kind!r}")
    return kind  # type: ignore[return-value]


def _check_signals(values: object, name: str, ndim: int) -> np.ndarray:
    """A finite float array of the given ndim with at least MIN_POINTS points per signal."""
    array = as_float_array(values, name, ndim)
    if array.size == 0:
        raise ValueError(f"{name} is empty")
    rows = array.reshape(-1, array.shape[-1])
    if rows.shape[1] < MIN_POINTS:
        raise ValueError(f"{name} has {rows.shape[1]} points per profile: a spectrum needs at least {MIN_POINTS}")
    bad = ~np.isfinite(rows)
    if bad.any():
        row, index = (int(i) for i in np.argwhere(bad)[0])
        kind = "NaN" if np.isnan(rows[row, index]) else "inf"
        where = f"{name} row {row}" if ndim == 2 else name
        raise ValueError(f"{where} contains a non-finite value ({kind}) at index {index}; "
                         "interpolate drop-outs first")
    return array


def _window_and_detrend(periodic: bool, window: object, detrend: object) -> tuple[Window, Detrend | None]:
    if periodic:
        if window is not None or detrend is not None:
            raise ValueError("window and detrend apply only to periodic=False: a periodic signal is analysed "
                             "as it is (no window, no trend), so leave them unset")
        return "rectangular", None
    window = "hann" if window is None else window
    detrend = "linear" if detrend is None else detrend
    if window not in ("hann", "rectangular"):
        raise ValueError(f"window must be 'hann' or 'rectangular', got {window!r}")
    if detrend not in ("linear", "mean"):
        raise ValueError(f"detrend must be 'linear' or 'mean', got {detrend!r}")
    return window, detrend  # type: ignore[return-value]


# --------------------------------------------------------------------------------------------------
# Bands
# --------------------------------------------------------------------------------------------------

def nominal_label(band: int) -> str:
    """The nominal wavelength of band ``band`` in millimetres, as acousticians write it ("31.5", "8")."""
    decade, step = divmod(int(band), 10)
    return f"{_R10[step] * 10.0 ** (2 - decade):.4g}"


def _bands(kind: BandKind) -> np.ndarray:
    return np.array(THIRD_OCTAVE_BANDS if kind == "third_octave" else OCTAVE_BANDS, dtype=np.int64)


def _line_bands(n_points: int, dx: float, kind: BandKind) -> np.ndarray:
    """Band index of each DFT line k = 1 .. n_points // 2."""
    frequency = np.arange(1, n_points // 2 + 1) / (n_points * dx)  # cycles per metre
    third = np.floor(10.0 * np.log10(frequency) + 0.5).astype(np.int64)
    # Octave n = 3m holds the third octaves 3m-1, 3m, 3m+1.
    return third if kind == "third_octave" else 3 * np.floor_divide(third + 1, 3)


def _points(dx: float, length: float) -> int:
    n_points = int(round(length / dx))
    if n_points < MIN_POINTS:
        raise ValueError(f"length {length:g} m holds {n_points} points of dx {dx:g} m: "
                         f"a spectrum needs at least {MIN_POINTS}")
    return n_points


def band_table(dx: float, length: float, kind: BandKind = "third_octave", *,
               min_points_per_wavelength: float = MIN_POINTS_PER_WAVELENGTH,
               min_wavelengths_per_length: float = MIN_WAVELENGTHS_PER_LENGTH) -> pl.DataFrame:
    """The ISO 13473-4 bands for a profile of evaluation length ``length`` sampled every ``dx``.

    Args:
        dx: sampling interval (m).
        length: evaluation length (m), N dx for N points.
        kind: "third_octave" (500 mm to 0.4 mm) or "octave" (500 mm to 0.5 mm).
        min_points_per_wavelength: sampling limit, centre wavelength >= this times dx.
        min_wavelengths_per_length: evaluation-length limit, length >= this times the centre wavelength.

    Returns:
        One row per band, longest wavelength first, with columns
        ``band`` (int n; centre 10^(-n/10) m), ``label`` (nominal wavelength in mm, e.g. "8", "3.15"),
        ``nominal_wavelength``, ``centre_wavelength`` (exact), ``lower_wavelength``,
        ``upper_wavelength`` (all m), ``lines`` (DFT lines the band holds), ``reported`` (bool: both
        limits met) and ``reason`` (why not reported; null when reported).
    """
    kind = _check_kind(kind)
    dx = positive(dx, "dx", "metres")
    length = positive(length, "length", "metres")
    per_wavelength = positive(min_points_per_wavelength, "min_points_per_wavelength", "sampling intervals")
    per_length = positive(min_wavelengths_per_length, "min_wavelengths_per_length", "wavelengths")
    n_points = _points(dx, length)
    length = n_points * dx
    bands = _bands(kind)
    half = 0.5 if kind == "third_octave" else 1.5
    centre = 10.0 ** (-bands / 10.0)
    line_bands = _line_bands(n_points, dx, kind)
    lines = np.array([np.count_nonzero(line_bands == b) for b in bands], dtype=np.int64)

    # An octave is reported when its three third octaves are: the sampling limit bites on its
    # shortest third octave (n + 1), the length limit on its longest (n - 1).
    shortest = 10.0 ** (-(bands + (half - 0.5)) / 10.0)
    longest = 10.0 ** (-(bands - (half - 0.5)) / 10.0)
    slack = 1.0 - 1e-9  # exact ties (e.g. 1 mm at dx = 0.4 mm) count as met despite rounding
    sampled = shortest >= per_wavelength * dx * slack
    long_enough = length >= per_length * longest * slack
    short_name, long_name = (("centre wavelength", "centre wavelength") if kind == "third_octave" else
                             ("centre wavelength of its shortest third octave",
                              "centre wavelength of its longest third octave"))
    reasons: list[str | None] = []
    for ok_sampling, ok_length, short, long_ in zip(sampled, long_enough, shortest, longest):
        why = []
        if not ok_sampling:
            why.append(f"{short_name}, {short * 1e3:.4g} mm, is under {per_wavelength:g} sampling intervals "
                       f"({per_wavelength * dx * 1e3:.4g} mm)")
        if not ok_length:
            why.append(f"evaluation length {length * 1e3:.4g} mm is under {per_length:g} times the {long_name} "
                       f"({per_length * long_ * 1e3:.4g} mm)")
        reasons.append("; ".join(why) or None)
    return pl.DataFrame({
        "band": bands,
        "label": [nominal_label(b) for b in bands],
        "nominal_wavelength": [float(nominal_label(b)) * 1e-3 for b in bands],
        "centre_wavelength": centre,
        "lower_wavelength": 10.0 ** (-(bands + half) / 10.0),
        "upper_wavelength": 10.0 ** (-(bands - half) / 10.0),
        "lines": lines,
        "reported": sampled & long_enough,
        "reason": pl.Series("reason", reasons, dtype=pl.String),
    })


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
    """

    bands: pl.DataFrame
    mean_square: np.ndarray
    levels: np.ndarray
    reference: float
    dx: float
    periodic: bool

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


def _detrended(block: np.ndarray, detrend: Detrend) -> np.ndarray:
    centred = block - block.mean(axis=1, keepdims=True)
    if detrend == "mean":
        return centred
    # Least-squares line through the points: x centred, so offset and slope separate.
    x = np.arange(block.shape[1], dtype=np.float64) - 0.5 * (block.shape[1] - 1)
    slope = centred @ x / (x @ x)
    return centred - slope[:, None] * x[None, :]


def band_levels(values: np.ndarray | Sequence[Sequence[float]], dx: float, *, kind: BandKind = "third_octave",
                reference: float = REFERENCE_TEXTURE, periodic: bool = False, window: Window | None = None,
                detrend: Detrend | None = None) -> BandLevels:
    """Band levels of many signals at once (vectorised numpy: FFT by blocks of rows, then a band sum).

    Args:
        values: 2-D array, one signal (profile heights in m, or pressures in Pa) per row, N >= 8 points.
        dx: sampling interval (m).
        kind: "third_octave" or "octave".
        reference: level reference in the signal's unit (default 1e-6 m, for texture).
        periodic: True for signals that repeat with period N dx (periodic contact-model output): exact
            DFT, no window, no detrending. False (default) for measured profiles: detrend, then window.
        window: "hann" (default when ``periodic=False``) or "rectangular"; only for ``periodic=False``.
        detrend: "linear" (default when ``periodic=False``, offset and slope suppression) or "mean";
            only for ``periodic=False``.

    Returns:
        A :class:`BandLevels` with every candidate band and its ``reported`` flag.

    Raises:
        ValueError: not 2-D, fewer than 8 points, NaN or inf, non-positive dx or reference, unknown kind,
            window or detrend, or window/detrend given with ``periodic=True``.
    """
    kind = _check_kind(kind)
    signals = _check_signals(values, "values", 2)
    dx = positive(dx, "dx", "metres")
    reference = positive(reference, "reference", "the signal's unit")
    window, detrend = _window_and_detrend(bool(periodic), window, detrend)
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
    line_band = _line_bands(n_points, dx, kind)
    first_line = np.searchsorted(line_band, bands, side="left")
    end_line = np.searchsorted(line_band, bands, side="right")
    filled = end_line > first_line

    mean_square = np.empty((n_signals, bands.size))
    rows_per_block = max(1, _BLOCK_VALUES // n_points)
    for start in range(0, n_signals, rows_per_block):
        block = signals[start:start + rows_per_block]
        if detrend is not None:
            block = _detrended(block, detrend)
        if window == "hann":
            block = block * taper
        spectrum = np.fft.rfft(block, axis=1)[:, 1:n_points // 2 + 1]
        power = (spectrum.real**2 + spectrum.imag**2) * line_weight
        sums = np.zeros((power.shape[0], bands.size))
        if filled.any():
            sums[:, filled] = np.add.reduceat(power, first_line[filled], axis=1)
            # reduceat runs each slice to the next start: trim the last filled band to its own end.
            last = np.flatnonzero(filled)[-1]
            sums[:, last] = power[:, first_line[last]:end_line[last]].sum(axis=1)
        mean_square[start:start + rows_per_block] = sums

    mean_square[:, table["lines"].to_numpy() == 0] = np.nan
    with np.errstate(divide="ignore"):
        levels = 10.0 * np.log10(mean_square / reference**2)
    return BandLevels(table, mean_square, levels, reference, dx, bool(periodic))


def _levels_frame(values: object, dx: float, name: str, kind: BandKind, reference: float, periodic: bool,
                  window: Window | None, detrend: Detrend | None) -> pl.DataFrame:
    signal = _check_signals(values, name, 1)
    result = band_levels(signal[None, :], dx, kind=kind, reference=reference, periodic=periodic,
                         window=window, detrend=detrend)
    return result.bands.with_columns(pl.Series("mean_square", result.mean_square[0]),
                                     pl.Series("level_db", result.levels[0]))


def third_octave_levels(heights: np.ndarray | Sequence[float], dx: float, *, reference: float = REFERENCE_TEXTURE,
                        periodic: bool = False, window: Window | None = None,
                        detrend: Detrend | None = None) -> pl.DataFrame:
    """One-third-octave texture spectrum of one profile (ISO 13473-4, DFT method).

    Args:
        heights: profile heights (m), N >= 8 points, no NaN (interpolate drop-outs first).
        dx: sampling interval (m).
        reference: level reference (m), default 1e-6 m.
        periodic: False (default) for a measured profile: linear detrend and Hann window. True for a
            periodic signal such as the enveloped profile of the periodic contact model: exact DFT.
        window, detrend: see :func:`band_levels` (``periodic=False`` only).

    Returns:
        The :func:`band_table` columns plus ``mean_square`` (m^2) and ``level_db``
        (20 lg(a_rms / reference)), one row per band from 500 mm to 0.4 mm.
    """
    return _levels_frame(heights, dx, "heights", "third_octave", reference, periodic, window, detrend)


def octave_levels(heights: np.ndarray | Sequence[float], dx: float, *, reference: float = REFERENCE_TEXTURE,
                  periodic: bool = False, window: Window | None = None,
                  detrend: Detrend | None = None) -> pl.DataFrame:
    """Octave-band texture spectrum of one profile, 500 mm to 0.5 mm; as :func:`third_octave_levels`.

    Each octave's mean square is exactly the sum of its three third octaves'.
    """
    return _levels_frame(heights, dx, "heights", "octave", reference, periodic, window, detrend)


def pressure_levels(pressure: np.ndarray | Sequence[float], dx: float, *, reference: float = REFERENCE_PRESSURE,
                    kind: BandKind = "third_octave", periodic: bool = True, window: Window | None = None,
                    detrend: Detrend | None = None) -> pl.DataFrame:
    """Band spectrum of a contact pressure distribution p(x) (Pa), e.g. ``roadtex.contact(...).pressure``.

    The level is 20 lg(p_rms / reference) with reference 1 Pa by default (``REFERENCE_PRESSURE``); the
    mean pressure is the k = 0 line and is in no band. ``periodic=True`` by default because the periodic
    contact model's pressure repeats with period N dx; pass ``periodic=False`` for the finite model.

    Returns:
        The :func:`band_table` columns plus ``mean_square`` (Pa^2) and ``level_db``.
    """
    return _levels_frame(pressure, dx, "pressure", _check_kind(kind), reference, periodic, window, detrend)


# --------------------------------------------------------------------------------------------------
# Time frequency, differences, regressions
# --------------------------------------------------------------------------------------------------

def time_frequency(wavelength_m: float | np.ndarray, speed_kmh: float) -> float | np.ndarray:
    """Temporal frequency f = V / wavelength (Hz) excited by texture of that wavelength (m) at V (km/h).

    The conversion Clapp used: a vehicle at V km/h passes V / 3.6 metres of road per second, so a
    wavelength of 8 mm at 80 km/h excites 22.2 / 0.008 = 2,778 Hz.
    """
    speed = positive(speed_kmh, "speed_kmh", "km/h")
    wavelength = np.asarray(wavelength_m, dtype=np.float64)
    if not np.all(np.isfinite(wavelength) & (wavelength > 0.0)):
        raise ValueError("wavelength_m must be positive finite wavelengths in metres")
    frequency = speed / 3.6 / wavelength
    return float(frequency) if frequency.ndim == 0 else frequency


def with_time_frequency(table: pl.DataFrame, speed_kmh: float) -> pl.DataFrame:
    """Adds the time-frequency band (Hz) at vehicle speed ``speed_kmh`` to a band table.

    Adds ``speed_kmh``, ``centre_frequency``, ``lower_frequency`` (from ``upper_wavelength``) and
    ``upper_frequency`` (from ``lower_wavelength``), all f = V / wavelength.
    """
    speed = positive(speed_kmh, "speed_kmh", "km/h")
    missing = {"centre_wavelength", "lower_wavelength", "upper_wavelength"} - set(table.columns)
    if missing:
        raise ValueError(f"table lacks the band columns {sorted(missing)}; pass a band_table or levels table")
    metres_per_second = speed / 3.6
    return table.with_columns(
        pl.lit(speed).alias("speed_kmh"),
        (metres_per_second / pl.col("centre_wavelength")).alias("centre_frequency"),
        (metres_per_second / pl.col("upper_wavelength")).alias("lower_frequency"),
        (metres_per_second / pl.col("lower_wavelength")).alias("upper_frequency"),
    )


_NOT_KEYS = set(BAND_COLUMNS) | set(FREQUENCY_COLUMNS) | {"mean_square", "level_db"}


def level_differences(enveloped: pl.DataFrame, original: pl.DataFrame, *, level: str = "level_db",
                      on: Sequence[str] | None = None) -> pl.DataFrame:
    """Enveloped-minus-original level per band (the seed's figure 4.4, bottom).

    Analyse both profiles the same way. For segments solved by the periodic contact model, that means
    ``periodic=True`` for the original too: the model sees the segment as one period, and its envelope
    is exactly periodic. Mixing a windowed original with a periodic envelope shifts the long bands by
    window bias (a few dB at 12 wavelengths per segment), which is not envelopment.

    Args:
        enveloped: levels of enveloped profiles; may carry extra keys such as ``youngs_modulus``.
        original: levels of the original profiles, one row per key.
        level: the level column in both tables.
        on: key columns; by default ``band`` plus every other column both tables share, except band
            metadata, frequency columns, ``mean_square`` and the level (e.g. ``site``, ``segment``).

    Returns:
        ``enveloped`` with ``original_level_db`` and ``level_difference_db`` (dB) added; null where the
        original has no row for the key.
    """
    for name, table in (("enveloped", enveloped), ("original", original)):
        if level not in table.columns or "band" not in table.columns:
            raise ValueError(f"{name} must have the columns 'band' and {level!r}, has {table.columns}")
    if on is None:
        keys = ["band"] + [c for c in enveloped.columns
                           if c in original.columns and c not in _NOT_KEYS and c != level]
    else:
        keys = list(on)
        missing = [c for c in keys if c not in enveloped.columns or c not in original.columns]
        if missing:
            raise ValueError(f"key columns {missing} are not in both tables")
    reference = original.select(*keys, pl.col(level).alias("original_level_db"))
    if reference.select(keys).is_duplicated().any():
        raise ValueError(f"original has more than one row for some ({', '.join(keys)}); "
                         "pass on= with the columns that identify a profile")
    joined = enveloped.join(reference, on=keys, how="left", maintain_order="left")
    return joined.with_columns((pl.col(level) - pl.col("original_level_db")).alias("level_difference_db"))


def band_regressions(table: pl.DataFrame, *, x: str = "texture_level", y: str = "pressure_level",
                     by: Sequence[str] = ("band", "youngs_modulus")) -> pl.DataFrame:
    """Least-squares line y = slope x + intercept per group (the seed's figure 4.6: per band and E).

    Rows with a non-finite x or y (NaN, -inf levels) are left out of the fit.

    Returns:
        One row per group, sorted by ``by``: the ``by`` columns, ``label`` and ``centre_wavelength`` when
        present in ``table``, ``slope`` (dB/dB), ``intercept`` (dB), ``r2`` and ``n`` (rows used). slope
        and intercept are NaN with fewer than 2 distinct x; r2 is NaN when y is constant.
    """
    by = [by] if isinstance(by, str) else list(by)
    missing = [c for c in (*by, x, y) if c not in table.columns]
    if missing:
        raise ValueError(f"table lacks the columns {missing}; it has {table.columns}")
    ok = pl.col(x).cast(pl.Float64).is_finite() & pl.col(y).cast(pl.Float64).is_finite()
    xs, ys = pl.col(x).cast(pl.Float64).filter(ok), pl.col(y).cast(pl.Float64).filter(ok)
    carried = [pl.col(c).first() for c in ("label", "centre_wavelength") if c in table.columns and c not in by]
    grouped = table.group_by(by, maintain_order=True).agg(
        *carried,
        ok.sum().cast(pl.Int64).alias("n"),
        xs.mean().alias("_mx"), ys.mean().alias("_my"),
        ((xs - xs.mean()) ** 2).sum().alias("_sxx"),
        ((ys - ys.mean()) ** 2).sum().alias("_syy"),
        ((xs - xs.mean()) * (ys - ys.mean())).sum().alias("_sxy"),
    )
    fit = (pl.col("n") >= 2) & (pl.col("_sxx") > 0.0)
    slope = pl.when(fit).then(pl.col("_sxy") / pl.col("_sxx")).otherwise(float("nan"))
    return (grouped
            .with_columns(slope.alias("slope"))
            .with_columns(
                (pl.col("_my") - pl.col("slope") * pl.col("_mx")).alias("intercept"),
                pl.when(fit & (pl.col("_syy") > 0.0))
                .then(pl.col("_sxy") ** 2 / (pl.col("_sxx") * pl.col("_syy"))).otherwise(float("nan")).alias("r2"))
            .select(*by, *[c for c in ("label", "centre_wavelength") if c in table.columns and c not in by],
                    "slope", "intercept", "r2", "n")
            .sort(by))
