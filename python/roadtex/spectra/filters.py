"""One-third-octave and octave band FILTERING (ISO 13473-4:2024's normative method; IEC 61260-1 class 1
filters), as a real analyser does it: a bank of digital band-pass filters run along the profile, with
octave-wise downsampling for the long-wavelength bands.

**Design.** Each band is a Butterworth band-pass (scipy.signal ``butter(..., btype="bandpass",
output="sos")``) whose -3 dB points are the band edges 10^(-(n +- 1/2)/10) m (octaves:
10^(-(n +- 3/2)/10) m); the bilinear transform is pre-warped at the edges, so they are exact. The
prototype order is 3 (a 6-pole band-pass in three second-order sections), which meets the class-1
mask (:data:`CLASS1_MASK`) with margin for a third octave centred at up to 0.2 of the sampling rate:
21 dB down at the octave-away breakpoint (17.5 required), 46 dB two octaves away (42), 0.6 dB at
G^(3/8) (1.3 allowed). Closer to Nyquist the bilinear warping widens the lower skirt, and an octave
band is wider: the order is raised band by band until the digital response meets the mask with 0.1 dB
to spare (order 4 for the few bands whose centre lies above about a fifth of the sampling rate).

**Decimation.** A band-pass whose centre is a tiny fraction of the sampling rate has poles crowded at
z = 1 and is badly conditioned. So each band is filtered at the rate 1 / (2^k dx) with the largest
k >= 0 that keeps its centre at no more than :data:`MAX_CENTRE` (0.2) of that rate (5 or more samples
per centre wavelength; the top bands, up to 0.4 of the rate, stay at k = 0). Going from one rate to the
next, the signal passes an anti-alias low-pass (Butterworth, order :data:`DECIMATION_ORDER` = 8, cut-off
:data:`DECIMATION_CUTOFF` = 0.22 of the faster rate, in second-order sections), and every other sample
is kept. Every band at the slower rate has its upper edge at no more than 0.113 of the faster rate
(0.141 for octaves), where the low-pass loses under 0.001 dB, and everything that would fold into it
lies above 0.359 of the faster rate, where the low-pass attenuates at least 74 dB (more than the class-1
mask's 70 dB floor). The filters are causal (``sosfilt``), as in an analyser; phase does not matter for
a level, and a zero-phase pass would square the magnitude response (-6 dB at the band edges, outside
the class-1 mask).

**Settling.** The transient of an IIR filter decays exponentially: for this band-pass, about 2.8 centre
wavelengths per neper. A band's settling length is where the tail of the impulse response of its whole
chain (the anti-alias stages before it, then the band filter) holds less than :data:`SETTLING_ENERGY`
(1e-3) of its energy: 10 to 13.5 centre wavelengths for a third octave, 6 to 7 for an octave
(anti-alias stages included).

- **Measured profiles** (``periodic=False``): detrended as for the DFT method, then filtered from the
  first sample; the first settling length of each band's output is discarded and the band's mean square
  is the mean of the squared output over the rest. No window. A band is ``reported`` only where the
  sampling limit holds and the length left after settling is at least 12 centre wavelengths (the
  evaluation-length limit of :mod:`roadtex.spectra.bands`, applied after settling); a band with no
  sample left gets NaN.
- **Periodic signals** (``periodic=True``: the enveloped profile or the pressure of the periodic contact
  model, which repeat with period L = N dx exactly): at each rate the signal is held as one period, and
  each filter (anti-alias stages included) runs over wrapped copies of it (indices taken modulo the
  period) for its settling length before the period that is measured. The output is then the
  steady-state response to the infinitely repeated signal, to 1e-8 of the energy
  (:data:`PERIODIC_SETTLING_ENERGY`, cheap because it is paid at the decimated rate), and the mean square
  is over exactly one period, so no edge is lost and the reporting limits are those of the DFT method.
  A period of odd length cannot be halved: it is then kept whole (two periods decimated) at the next
  rate. Bands whose frequency range lies wholly below 1 / L (no DFT line) see only the filter's skirt
  of the lowest harmonics, as an analyser would.

The band edges, centres, labels and limits are those of :mod:`roadtex.spectra.bands`. All designs
depend only on dx and the kind of band, and are cached.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from roadtex.spectra.bands import BandKind, band_numbers

BAND_ORDER = 3
"""Order of each band's Butterworth prototype (a 6-pole band-pass), raised band by band (up to
:data:`MAX_BAND_ORDER`) until the digital response meets the class-1 mask with :data:`MASK_MARGIN`."""

MAX_BAND_ORDER = 8
"""Highest prototype order tried."""

MASK_MARGIN = 0.1
"""dB kept inside the class-1 mask by each band filter's design (checked on its frequency response)."""

DECIMATION_ORDER = 8
"""Order of the anti-alias Butterworth low-pass applied before each halving of the sampling rate."""

DECIMATION_CUTOFF = 0.22
"""Cut-off of the anti-alias low-pass, as a fraction of the sampling rate it runs at."""

MAX_CENTRE = 0.2
"""A band is filtered at the slowest halved rate where its centre frequency is at most this fraction of
the rate (5 samples per centre wavelength)."""

SETTLING_ENERGY = 1e-3
"""Measured profiles: output discarded until the impulse response's remaining energy is below this
fraction of its total (so the transient biases the mean square by about this fraction or less)."""

PERIODIC_SETTLING_ENERGY = 1e-8
"""Periodic signals: wrapped run-in until the impulse response's remaining energy is below this fraction."""

# IEC 61260-1 class-1 acceptance limits for band filters, as gain relative to the reference (mid-band)
# gain, at the octave-band breakpoints Omega_oct = G^x (G = 10^(3/10)); fractional bands (1/b octave)
# map them to Omega = 1 + (G^(1/(2b)) - 1) / (G^(1/2) - 1) (Omega_oct - 1) above the centre, and to
# its reciprocal below. Between breakpoints the limits are interpolated linearly in log frequency;
# beyond G^4 the -70 dB floor holds.
CLASS1_MASK = (
    # (x in G^x, lowest gain allowed dB, highest gain allowed dB)
    (0.0, -0.3, 0.3),
    (1 / 8, -0.4, 0.3),
    (1 / 4, -0.6, 0.3),
    (3 / 8, -1.3, 0.3),
    (1 / 2, -5.0, -2.0),      # the band edge: attenuated 2 to 5 dB (-3 dB for a Butterworth)
    (1.0, -np.inf, -17.5),
    (2.0, -np.inf, -42.0),
    (3.0, -np.inf, -61.0),
    (4.0, -np.inf, -70.0),
)
"""Class-1 relative-attenuation limits of IEC 61260:1995 (= ANSI S1.11-2004 class 1), in gain (dB):
the table (breakpoint, min, max) of the public implementations cited in docs/guide/spectra.md (the text of the
2014 edition, IEC 61260-1:2014, was not at hand; its limits are acceptance limits that include the
measurement uncertainty and are no tighter). Between G^(3/8) and G^(1/2) the upper limit stays +0.3
and the lower one falls to -5; just above G^(1/2) the upper limit drops to -2."""

G = 10.0 ** 0.3
"""Octave ratio of the base-10 system, 10^(3/10)."""


def class1_limits(omega: np.ndarray, kind: BandKind) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest gain (dB, relative to mid-band) class 1 allows at normalised frequencies
    ``omega`` = f / f_centre (> 0) for a third-octave (b = 3) or octave (b = 1) filter."""
    b = 3 if kind == "third_octave" else 1
    x = np.array([row[0] for row in CLASS1_MASK])
    low = np.array([row[1] for row in CLASS1_MASK])
    high = np.array([row[2] for row in CLASS1_MASK])
    breakpoints = 1.0 + (G ** (1 / (2 * b)) - 1) / (G ** 0.5 - 1) * (G ** x - 1)
    omega = np.asarray(omega, dtype=np.float64)
    distance = np.log(np.where(omega >= 1.0, omega, 1.0 / omega))
    log_breaks = np.log(breakpoints)
    edge = log_breaks[4]
    # Upper limit: +0.3 up to the edge (inclusive of the edge's own -2 only at and beyond it).
    finite_low = np.isfinite(low)
    lower = np.where(distance <= edge, np.interp(distance, log_breaks[finite_low], low[finite_low]), -np.inf)
    upper = np.where(distance < edge * (1 - 1e-12), 0.3, np.interp(distance, log_breaks[4:], high[4:]))
    return lower, upper


@dataclass(frozen=True)
class BandFilter:
    """One band of the bank: its index, decimation level and second-order sections."""

    band: int
    level: int          # filtered at the sampling interval dx * 2^level
    sos: np.ndarray
    settle: int         # samples at its own rate discarded (measured profiles), whole chain included
    periodic_settle: int  # run-in samples of the band filter alone at its own rate (periodic signals)


@dataclass(frozen=True)
class FilterBank:
    """The bank for one (dx, kind): band filters, the anti-alias low-pass, and its run-in lengths."""

    dx: float
    kind: BandKind
    bands: tuple[BandFilter | None, ...]  # one per candidate band; None where no filter fits below Nyquist
    decimator: np.ndarray
    decimator_settle: int  # anti-alias run-in samples for periodic signals (at the faster rate)
    levels: int


def _tail_settle(sos: np.ndarray, fraction: float) -> int:
    """Samples after which the impulse response of ``sos`` keeps less than ``fraction`` of its energy."""
    from scipy import signal  # scipy on first use: the command line starts without it
    length = 1 << 10
    while True:
        x = np.zeros(length)
        x[0] = 1.0
        energy = signal.sosfilt(sos, x) ** 2
        tail = np.cumsum(energy[::-1])[::-1]
        if tail[0] <= 0.0:
            return 0
        if tail[-1] / tail[0] < fraction * 1e-3 or length >= 1 << 22:
            return int(np.argmax(tail / tail[0] < fraction))
        length <<= 2


def _band_design(low: float, centre: float, high: float, kind: BandKind) -> np.ndarray:
    """The lowest-order Butterworth band-pass (edges low, high in cycles per sample) whose response
    meets the class-1 mask with MASK_MARGIN, checked on a dense grid up to Nyquist."""
    from scipy import signal  # scipy on first use: the command line starts without it
    omega = np.geomspace(1e-3 / centre, 0.4999 / centre, 4000)
    lower, upper = class1_limits(omega, kind)
    for order in range(BAND_ORDER, MAX_BAND_ORDER + 1):
        sos = signal.butter(order, [2 * low, 2 * high], btype="bandpass", output="sos")
        _, response = signal.sosfreqz(sos, worN=2 * np.pi * np.append(omega, 1.0) * centre)
        with np.errstate(divide="ignore"):
            gain = 20 * np.log10(np.abs(response))
        gain = gain[:-1] - gain[-1]
        if np.all(gain >= lower + MASK_MARGIN) and np.all(gain <= upper - MASK_MARGIN):
            return sos
    return sos  # not reached for the bands of ISO 13473-4 within the sampling limit (tests check the mask)


@lru_cache(maxsize=64)
def filter_bank(dx: float, kind: BandKind) -> FilterBank:
    """The band filters for sampling interval ``dx`` (m) and ``kind``: see the module docstring."""
    from scipy import signal  # scipy on first use: the command line starts without it
    half = 0.5 if kind == "third_octave" else 1.5
    numbers = band_numbers(kind)
    decimator = signal.butter(DECIMATION_ORDER, 2 * DECIMATION_CUTOFF, btype="lowpass", output="sos")
    decimator_settle = _tail_settle(decimator, PERIODIC_SETTLING_ENERGY)
    decimator_discard = _tail_settle(decimator, SETTLING_ENERGY)
    filters: list[BandFilter | None] = []
    for n in numbers:
        centre = 10.0 ** (n / 10.0) * dx            # cycles per sample at the full rate
        low, high = 10.0 ** ((n - half) / 10.0) * dx, 10.0 ** ((n + half) / 10.0) * dx
        if high >= 0.5:
            filters.append(None)
            continue
        level = max(0, int(np.floor(np.log2(MAX_CENTRE / centre))))
        scale = float(1 << level)
        sos = _band_design(low * scale, centre * scale, high * scale, kind)
        # The chain's transients add up: the band filter's own, plus each anti-alias stage's, in
        # samples of this band's rate (a bound: the cascade settles no later than the sum).
        settle = _tail_settle(sos, SETTLING_ENERGY) + int(np.ceil(
            sum(decimator_discard / (1 << (level - j)) for j in range(level))))
        periodic_settle = _tail_settle(sos, PERIODIC_SETTLING_ENERGY)
        filters.append(BandFilter(int(n), level, sos, settle, periodic_settle))
    levels = 1 + max((f.level for f in filters if f is not None), default=0)
    return FilterBank(dx, kind, tuple(filters), decimator, decimator_settle, levels)


def _wrapped(block: np.ndarray, run_in: int) -> np.ndarray:
    """``run_in`` samples of the periodic signal's past (wrapped), then one period."""
    period = block.shape[1]
    index = np.arange(-run_in, period) % period
    return block[:, index]


def filtered_mean_squares(block: np.ndarray, bank: FilterBank, periodic: bool) -> tuple[np.ndarray, np.ndarray]:
    """Band mean squares of each row of ``block`` (already detrended when measured) by the filter bank.

    Returns (mean_square, measured_length): (rows, bands) mean squares (NaN where the band has no
    filter or no sample left after settling) and, per band, the length (m) the mean is taken over.
    """
    from scipy import signal  # scipy on first use: the command line starts without it
    n_bands = len(bank.bands)
    mean_square = np.full((block.shape[0], n_bands), np.nan)
    measured = np.zeros(n_bands)
    by_level: dict[int, list[int]] = {}
    for i, f in enumerate(bank.bands):
        if f is not None:
            by_level.setdefault(f.level, []).append(i)
    current = np.ascontiguousarray(block, dtype=np.float64)
    for level in range(bank.levels):
        step = bank.dx * (1 << level)
        for i in by_level.get(level, []):
            f = bank.bands[i]
            assert f is not None
            if periodic:
                out = signal.sosfilt(f.sos, _wrapped(current, f.periodic_settle), axis=1)[:, f.periodic_settle:]
            else:
                out = signal.sosfilt(f.sos, current, axis=1)[:, f.settle:]
            if out.shape[1] == 0:
                continue
            mean_square[:, i] = np.mean(out * out, axis=1)
            measured[i] = out.shape[1] * step
        if level + 1 == bank.levels:
            break
        if periodic:
            period = current.shape[1]
            run_in = bank.decimator_settle
            if period % 2:  # an odd period cannot be halved: decimate two periods into one
                current = np.concatenate([current, current], axis=1)
                period *= 2
            low = signal.sosfilt(bank.decimator, _wrapped(current, run_in), axis=1)[:, run_in:]
            current = low[:, ::2]
        else:
            if current.shape[1] < 2:
                break
            current = signal.sosfilt(bank.decimator, current, axis=1)[:, ::2]
    return mean_square, measured
