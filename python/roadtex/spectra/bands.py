"""The ISO 13473-4 wavelength bands: numbering, labels, limits, and which DFT line falls in which band.

Band ``n`` has the exact centre wavelength 10^(-n/10) m and edges at 10^(-(n +- 1/2)/10) m; octave
``n`` (n a multiple of 3) spans the third octaves n-1, n and n+1. See :mod:`roadtex.spectra` for
the method and the reporting limits.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import polars as pl

from roadtex._checks import as_float_array, positive
from roadtex.errors import InvalidInputError

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
R10 = (10.0, 8.0, 6.3, 5.0, 4.0, 3.15, 2.5, 2.0, 1.6, 1.25)

BAND_COLUMNS = ("band", "label", "nominal_wavelength", "centre_wavelength", "lower_wavelength",
                "upper_wavelength", "lines", "reported", "reason")
"""Columns of :func:`band_table`, in order."""

FREQUENCY_COLUMNS = ("speed_kmh", "centre_frequency", "lower_frequency", "upper_frequency")
"""Columns added by :func:`with_time_frequency`."""

# Rows per FFT block in band_levels: about 4 million values (32 MB) per block bounds memory.
BLOCK_VALUES = 1 << 22


# --------------------------------------------------------------------------------------------------
# Input checks
# --------------------------------------------------------------------------------------------------


#: Largest and smallest nonzero magnitude a spectrum's signal may reach: their squares, summed over
#: up to 1e8 points, stay normal float64 numbers (about 1e-308 to 1e308).
MAX_SIGNAL = 1e140
MIN_SIGNAL = 1e-140


def check_band_kind(kind: object) -> BandKind:
    if kind not in ("third_octave", "octave"):
        raise InvalidInputError(f"kind must be 'third_octave' or 'octave', got {kind!r}")
    return kind  # type: ignore[return-value]


def check_signals(values: object, name: str, ndim: int) -> np.ndarray:
    """A finite float array of the given ndim with at least MIN_POINTS points per signal."""
    array = as_float_array(values, name, ndim)
    if array.size == 0:
        raise InvalidInputError(f"{name} is empty")
    rows = array.reshape(-1, array.shape[-1])
    if rows.shape[1] < MIN_POINTS:
        raise InvalidInputError(f"{name} has {rows.shape[1]} points per profile: a spectrum needs at least {MIN_POINTS}")
    bad = ~np.isfinite(rows)
    if bad.any():
        row, index = (int(i) for i in np.argwhere(bad)[0])
        kind = "NaN" if np.isnan(rows[row, index]) else "inf"
        where = f"{name} row {row}" if ndim == 2 else name
        raise InvalidInputError(f"{where} contains a non-finite value ({kind}) at index {index}; "
                         "interpolate drop-outs first")
    biggest = float(np.max(np.abs(rows)))
    if biggest > MAX_SIGNAL or 0.0 < biggest < MIN_SIGNAL:
        raise InvalidInputError(f"{name} reach at most {biggest:.3g} (in the signal's unit): their band powers (squares "
                                f"summed) would {'overflow' if biggest > MAX_SIGNAL else 'underflow'} float64 and the "
                                f"levels come out {'inf' if biggest > MAX_SIGNAL else '-inf or NaN'}; give them in a "
                                f"unit that brings them within {MIN_SIGNAL:g} to {MAX_SIGNAL:g} (and the reference "
                                "in the same unit)")
    return array


def window_and_detrend(periodic: bool, window: object, detrend: object) -> tuple[Window, Detrend | None]:
    if periodic:
        if window is not None or detrend is not None:
            raise InvalidInputError("window and detrend apply only to periodic=False: a periodic signal is analysed "
                             "as it is (no window, no trend), so leave them unset")
        return "rectangular", None
    window = "hann" if window is None else window
    detrend = "linear" if detrend is None else detrend
    if window not in ("hann", "rectangular"):
        raise InvalidInputError(f"window must be 'hann' or 'rectangular', got {window!r}")
    if detrend not in ("linear", "mean"):
        raise InvalidInputError(f"detrend must be 'linear' or 'mean', got {detrend!r}")
    return window, detrend  # type: ignore[return-value]


# --------------------------------------------------------------------------------------------------
# Bands
# --------------------------------------------------------------------------------------------------

def nominal_label(band: int) -> str:
    """The nominal wavelength of band ``band`` in millimetres, as acousticians write it ("31.5", "8")."""
    decade, step = divmod(int(band), 10)
    return f"{R10[step] * 10.0 ** (2 - decade):.4g}"


def band_numbers(kind: BandKind) -> np.ndarray:
    return np.array(THIRD_OCTAVE_BANDS if kind == "third_octave" else OCTAVE_BANDS, dtype=np.int64)


def line_bands(n_points: int, dx: float, kind: BandKind) -> np.ndarray:
    """Band index of each DFT line k = 1 .. n_points // 2."""
    frequency = np.arange(1, n_points // 2 + 1) / (n_points * dx)  # cycles per metre
    return wavenumber_bands(frequency, kind)


def wavenumber_bands(wavenumber: np.ndarray, kind: BandKind) -> np.ndarray:
    """Band index of each spatial frequency (cycles per metre, > 0): the band whose edges bracket it
    (a frequency exactly on an edge goes to the band of shorter wavelength)."""
    third = np.floor(10.0 * np.log10(wavenumber) + 0.5).astype(np.int64)
    # Octave n = 3m holds the third octaves 3m-1, 3m, 3m+1.
    return third if kind == "third_octave" else 3 * np.floor_divide(third + 1, 3)


def points_in(dx: float, length: float) -> int:
    n_points = int(round(length / dx))
    if n_points < MIN_POINTS:
        raise InvalidInputError(f"length {length:g} m holds {n_points} points of dx {dx:g} m: "
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
    kind = check_band_kind(kind)
    dx = positive(dx, "dx", "metres")
    length = positive(length, "length", "metres")
    per_wavelength = positive(min_points_per_wavelength, "min_points_per_wavelength", "sampling intervals")
    per_length = positive(min_wavelengths_per_length, "min_wavelengths_per_length", "wavelengths")
    n_points = points_in(dx, length)
    length = n_points * dx
    bands = band_numbers(kind)
    half = 0.5 if kind == "third_octave" else 1.5
    centre = 10.0 ** (-bands / 10.0)
    band_of_line = line_bands(n_points, dx, kind)
    lines = np.array([np.count_nonzero(band_of_line == b) for b in bands], dtype=np.int64)

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

