"""Choosing the rubber's Young's modulus from noise: the E whose enveloped texture best explains noise.

The seed's conclusion proposes taking for E the value that gives the best correlation between the
texture levels of enveloped profiles and measured tyre/road noise. :func:`calibrate_modulus` does
that over a set of sites: for every E of a sweep it envelops each site's profile segments with the
periodic contact model (:func:`roadtex.contact_many`), computes the band levels of the enveloped
profiles (:func:`roadtex.spectra.band_levels`, exact periodic DFT), and correlates them across sites
with the measured noise levels, band by band.

**Score and best E.** Per (E, band): the Pearson correlation r across sites between the site's
enveloped texture level and its noise level in that band. Per E: the mean of r over the bands (signed:
more texture should mean more tyre-vibration noise, so a negative r counts against that E). The best
E is the grid value with the highest mean r.

**Uncertainty.** Sites are resampled with replacement (bootstrap, ``n_bootstrap`` times, fixed
``seed``); each resample picks its own best E. The reported interval is the central ``confidence``
range of those picks (grid values), and ``scores["bootstrap_share"]`` gives how often each E won. The
interval cannot be finer than the grid; a best E at the end of the grid is flagged (``at_grid_edge``)
because the optimum may lie beyond the sweep. The bootstrap measures how much the choice depends on
which sites were measured; it says nothing about whether the contact model explains the noise at all
(look at the correlations themselves for that).

**Texture level of a site.** Each segment is enveloped as one period of the periodic model; a site's
level in a band is the energy average over its segments, 10 lg(mean of the band mean squares /
(1e-6 m)^2). Only bands reported (ISO 13473-4 limits) for every site's segment length are used.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Hashable, Mapping, Sequence

import numpy as np
import polars as pl

from roadtex._checks import positive, positive_int
from roadtex.errors import InvalidInputError
from roadtex.models.contact import contact_many
from roadtex.spectra.bands import BLOCK_VALUES, REFERENCE_TEXTURE, BandKind, band_table, check_band_kind, check_signals, wavenumber_bands
from roadtex.spectra.levels import band_levels

DEFAULT_MODULI = tuple(float(f"{1e6 * 10 ** (k / 10):.4g}") for k in range(11))
"""The default sweep: 1 to 10 MPa in tenth-decade steps (1, 1.259, 1.585, ... 7.943, 10 MPa)."""

MIN_SITES = 3
"""A correlation across sites needs at least three sites."""

# Values per working array (contact envelopes, bootstrap levels): about 32 MB of float64.


@dataclass(frozen=True)
class CalibrationResult:
    """What :func:`calibrate_modulus` found.

    Attributes:
        best_modulus: the E (Pa) of the sweep with the highest mean correlation over bands.
        interval: (low, high) E (Pa): the central ``confidence`` range of the bootstrap's best E.
        confidence: the interval's coverage (e.g. 0.9).
        at_grid_edge: True when the best E is the smallest or largest of the sweep.
        scores: one row per E: ``youngs_modulus`` (Pa), ``mean_correlation`` (mean Pearson r over bands),
            ``bands`` (bands with a defined r), ``bootstrap_share`` (share of resamples whose best E it is).
        correlations: one row per (E, band): ``youngs_modulus``, ``band``, ``label``, ``centre_wavelength``
            (m), ``correlation`` (Pearson r across sites), ``r2``, ``slope`` (dB of noise per dB of texture),
            ``intercept`` (dB), ``sites``.
        texture_levels: one row per (site, E, band): the enveloped profile's level ``level_db`` (dB re
            1e-6 m), energy-averaged over the site's segments.
        noise_levels: the noise levels used, one row per (site, band): ``site``, ``band``, ``level_db``.
        n_bootstrap: number of bootstrap resamples.
    """

    best_modulus: float
    interval: tuple[float, float]
    confidence: float
    at_grid_edge: bool
    scores: pl.DataFrame
    correlations: pl.DataFrame
    texture_levels: pl.DataFrame
    noise_levels: pl.DataFrame
    n_bootstrap: int


def _pearson(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, ...]:
    """Pearson r, least-squares slope and intercept of y on x, and the count, along axis -2 (sites).

    Pairs where x or y is not finite are left out. r is NaN with fewer than 3 pairs or no spread.
    """
    x, y = np.broadcast_arrays(x, y)
    used = np.isfinite(x) & np.isfinite(y)
    count = used.sum(axis=-2)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_x = np.where(used, x, 0.0).sum(axis=-2) / count
        mean_y = np.where(used, y, 0.0).sum(axis=-2) / count
        dev_x = np.where(used, x - mean_x[..., None, :], 0.0)
        dev_y = np.where(used, y - mean_y[..., None, :], 0.0)
        sxx, syy = (dev_x**2).sum(axis=-2), (dev_y**2).sum(axis=-2)
        sxy = (dev_x * dev_y).sum(axis=-2)
        defined = (count >= MIN_SITES) & (sxx > 0.0) & (syy > 0.0)
        r = np.where(defined, sxy / np.sqrt(sxx * syy), np.nan)
        slope = np.where(defined, sxy / sxx, np.nan)
    return r, slope, mean_y - slope * mean_x, count


def _nanmean(values: np.ndarray, axis: int) -> np.ndarray:
    """Mean of the finite values along ``axis``; NaN (without a warning) where there are none."""
    finite = np.isfinite(values)
    count = finite.sum(axis=axis)
    total = np.where(finite, values, 0.0).sum(axis=axis)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def _site_profiles(profiles: object) -> tuple[list[Hashable], list[np.ndarray]]:
    if isinstance(profiles, Mapping):
        sites, arrays = list(profiles.keys()), list(profiles.values())
    elif isinstance(profiles, np.ndarray) and profiles.ndim in (2, 3):
        # (sites, points): one profile per site; (sites, segments, points): segments per site.
        sites, arrays = list(range(profiles.shape[0])), list(profiles)
    elif isinstance(profiles, Sequence) and not isinstance(profiles, (str, bytes)):
        sites, arrays = list(range(len(profiles))), list(profiles)
    else:
        raise InvalidInputError("profiles must be a mapping site -> profile(s) or a sequence of profiles, one per site")
    if len(sites) < MIN_SITES:
        raise InvalidInputError(f"profiles has {len(sites)} sites: a correlation across sites needs at least {MIN_SITES}")
    segments = []
    for site, array in zip(sites, arrays):
        try:
            ndim = 1 if np.ndim(array) == 1 else 2
        except ValueError:  # ragged nested sequences
            ndim = 2
        checked = check_signals(array, f"profiles[{site!r}]", ndim)
        segments.append(checked.reshape(-1, checked.shape[-1]))
    return sites, segments


def _noise_table(noise_levels: object, sites: list[Hashable], kind: BandKind, bands: Sequence[int] | None,
                 speed_kmh: float | None) -> dict[tuple[Hashable, int], float]:
    """Noise levels keyed by (site, band index)."""
    if isinstance(noise_levels, pl.DataFrame):
        if "site" not in noise_levels.columns or "level_db" not in noise_levels.columns:
            raise InvalidInputError(f"noise_levels needs the columns 'site', 'level_db' and 'band' (or 'frequency' with "
                             f"speed_kmh); it has {noise_levels.columns}")
        if "band" in noise_levels.columns:
            band_index = noise_levels["band"].cast(pl.Int64).to_list()
        elif "frequency" in noise_levels.columns:
            if speed_kmh is None:
                raise InvalidInputError("noise_levels gives 'frequency' (Hz): pass speed_kmh to map it to wavelength bands")
            speed = positive(speed_kmh, "speed_kmh", "km/h")
            frequency = noise_levels["frequency"].cast(pl.Float64).to_numpy()
            if not np.all(np.isfinite(frequency) & (frequency > 0.0)):
                raise InvalidInputError("noise_levels frequency must be positive finite values in Hz")
            # Texture of wavelength V / f excites f: the band whose edges bracket that wavelength.
            band_index = wavenumber_bands(frequency / (speed / 3.6), kind).tolist()
        else:
            raise InvalidInputError(f"noise_levels needs a 'band' (wavelength band index n) or 'frequency' (Hz) column; "
                             f"it has {noise_levels.columns}")
        site_column = noise_levels["site"].to_list()
        levels = noise_levels["level_db"].cast(pl.Float64).to_numpy()
    else:
        array = np.asarray(noise_levels, dtype=np.float64)
        if bands is None:
            raise InvalidInputError("noise_levels given as an array needs bands=, the band index n of each column")
        band_list = [int(b) for b in bands]
        if array.shape != (len(sites), len(band_list)):
            raise InvalidInputError(f"noise_levels must have shape (sites, bands) = ({len(sites)}, {len(band_list)}), "
                             f"got {array.shape}")
        site_column = [site for site in sites for _ in band_list]
        band_index = band_list * len(sites)
        levels = array.reshape(-1)
    if not np.all(np.isfinite(levels)):
        raise InvalidInputError("noise_levels level_db contains NaN or inf; leave missing (site, band) rows out instead")
    table: dict[tuple[Hashable, int], float] = {}
    for site, band, level in zip(site_column, band_index, levels):
        key = (site, int(band))
        if key in table:
            raise InvalidInputError(f"noise_levels has more than one level for site {site!r} in band {int(band)}"
                             + (" (two frequencies map to one wavelength band; give 'band' instead)"
                                if isinstance(noise_levels, pl.DataFrame) and "band" not in noise_levels.columns
                                else ""))
        table[key] = float(level)
    known = set(sites)
    unknown = sorted({repr(site) for site, _ in table if site not in known})
    if unknown:
        raise InvalidInputError(f"noise_levels has sites with no profile: {', '.join(unknown)}")
    present = {site for site, _ in table}
    silent = [repr(site) for site in sites if site not in present]
    if silent:
        raise InvalidInputError(f"noise_levels has no level for the sites {', '.join(silent)}")
    return table


def calibrate_modulus(
    profiles: Mapping[Hashable, np.ndarray] | Sequence[np.ndarray] | np.ndarray,
    dx: float,
    noise_levels: pl.DataFrame | np.ndarray,
    *,
    moduli: Sequence[float] = DEFAULT_MODULI,
    mean_pressure: float = 2e5,
    kind: BandKind = "third_octave",
    bands: Sequence[int] | None = None,
    speed_kmh: float | None = None,
    poisson: float = 0.5,
    tol: float = 1e-8,
    threads: int | None = None,
    n_bootstrap: int = 1000,
    confidence: float = 0.9,
    seed: int = 0,
) -> CalibrationResult:
    """Sweeps E and finds the value whose enveloped texture levels correlate best with noise.

    Args:
        profiles: per site, one profile (1-D) or its segments (2-D, one per row), heights in m; a mapping
            site -> array (site names are then the keys) or a sequence (sites 0, 1, ...). At least 3
            sites. Each segment is solved as one period of the periodic contact model.
        dx: sampling interval (m).
        noise_levels: measured noise per site and band, e.g. CPX one-third-octave levels (dB), either a
            polars DataFrame with ``site``, ``level_db`` and ``band`` (the wavelength band index n of
            :func:`roadtex.spectra.band_table`) or ``frequency`` (Hz, with ``speed_kmh``: mapped to the
            band holding the wavelength V / f), or an array (sites, bands) with ``bands=``.
        moduli: the E values to sweep (Pa), at least 2; default 1 to 10 MPa in tenth-decade steps.
        mean_pressure: tyre contact pressure P (Pa).
        kind: "third_octave" or "octave" bands.
        bands: band indices of the noise array's columns; with a DataFrame, optionally the bands to use.
        speed_kmh: vehicle speed (km/h) for noise given by frequency.
        poisson, tol, threads: passed to :func:`roadtex.contact_many`.
        n_bootstrap: resamples of the sites for the uncertainty.
        confidence: coverage of the reported interval, in (0, 1).
        seed: random seed of the bootstrap (results are reproducible).

    Returns:
        A :class:`CalibrationResult`. Only bands reported (ISO 13473-4 limits) for every site's segment
        length and present in the noise data are used.

    Raises:
        ValueError: bad input, named. ConvergenceError: a contact problem did not converge.
    """
    kind = check_band_kind(kind)
    dx = positive(dx, "dx", "metres")
    sites, segments = _site_profiles(profiles)
    grid = np.atleast_1d(np.asarray(moduli, dtype=np.float64))
    if grid.ndim != 1 or grid.size < 2:
        raise InvalidInputError(f"moduli must be a 1-D sequence of at least 2 values of E (Pa), got shape {grid.shape}")
    if not np.all(np.isfinite(grid) & (grid > 0.0)):
        raise InvalidInputError("moduli must be positive finite values of E in pascals")
    grid = np.unique(grid)
    n_bootstrap = positive_int(n_bootstrap, "n_bootstrap")
    confidence = positive(confidence, "confidence", "(a fraction)")
    if not confidence < 1.0:
        raise InvalidInputError(f"confidence must lie in (0, 1), got {confidence!r}")
    noise = _noise_table(noise_levels, sites, kind, bands, speed_kmh)

    # Bands reported for every site's segment length and present in the noise data.
    tables = {n: band_table(dx, n * dx, kind) for n in {s.shape[1] for s in segments}}
    reference_table = next(iter(tables.values()))
    usable = np.logical_and.reduce([t["reported"].to_numpy() for t in tables.values()])
    noise_bands = {band for _, band in noise}
    if bands is not None and isinstance(noise_levels, pl.DataFrame):
        noise_bands &= {int(b) for b in bands}
    usable &= np.isin(reference_table["band"].to_numpy(), sorted(noise_bands))
    if not usable.any():
        raise InvalidInputError(f"no band is both reported for these segment lengths and present in noise_levels "
                         f"(noise bands: {sorted(noise_bands)})")
    columns = np.flatnonzero(usable)
    used_bands = reference_table[columns]

    # Enveloped band levels per (E, site, band), energy-averaged over each site's segments. Sites are
    # solved one block of segments at a time so that memory stays bounded by BLOCK_VALUES.
    mean_square = np.zeros((grid.size, len(sites), columns.size))
    for site_index, site_segments in enumerate(segments):
        rows_per_block = max(1, BLOCK_VALUES // (grid.size * site_segments.shape[1]))
        for start in range(0, site_segments.shape[0], rows_per_block):
            block = site_segments[start:start + rows_per_block]
            batch = contact_many(block, dx, grid, mean_pressure, poisson=poisson, tol=tol, threads=threads)
            for e in range(grid.size):
                powers = band_levels(batch.envelope[:, e, :], dx, kind=kind, periodic=True).mean_square
                mean_square[e, site_index] += powers[:, columns].sum(axis=0)
        mean_square[:, site_index] /= site_segments.shape[0]
    with np.errstate(divide="ignore"):
        texture = 10.0 * np.log10(mean_square / REFERENCE_TEXTURE**2)
    band_ids = used_bands["band"].to_list()
    measured = np.array([[noise.get((site, band), np.nan) for band in band_ids] for site in sites])

    r, slope, intercept, count = _pearson(texture, measured[None, :, :])
    score = _nanmean(r, axis=1)
    if not np.isfinite(score).any():
        raise InvalidInputError("no correlation is defined: texture or noise levels do not vary across sites")
    best = int(np.nanargmax(score))

    # Bootstrap over sites, in blocks of resamples to bound the (E, resample, site, band) arrays.
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, len(sites), size=(n_bootstrap, len(sites)))
    resamples_per_block = max(1, BLOCK_VALUES // (grid.size * len(sites) * columns.size))
    winners_by_block = []
    for start in range(0, n_bootstrap, resamples_per_block):
        chosen = picks[start:start + resamples_per_block]
        r_boot = _pearson(texture[:, chosen, :], measured[chosen][None, ...])[0]  # (E, resample, band)
        score_boot = _nanmean(r_boot, axis=2)  # (E, resample); NaN when a resample repeats one site only
        valid = np.isfinite(score_boot).any(axis=0)
        winners_by_block.append(np.argmax(np.where(np.isfinite(score_boot), score_boot, -np.inf)[:, valid], axis=0))
    winners = np.concatenate(winners_by_block)
    share = np.bincount(winners, minlength=grid.size) / max(winners.size, 1)
    tail = (1.0 - confidence) / 2.0
    low = float(np.quantile(grid[winners], tail, method="lower")) if winners.size else float("nan")
    high = float(np.quantile(grid[winners], 1.0 - tail, method="higher")) if winners.size else float("nan")

    defined_bands = np.isfinite(r).sum(axis=1)
    scores = pl.DataFrame({"youngs_modulus": grid, "mean_correlation": score,
                           "bands": defined_bands.astype(np.int64), "bootstrap_share": share})
    n_e, n_b = grid.size, columns.size
    correlations = pl.DataFrame({
        "youngs_modulus": np.repeat(grid, n_b),
        "band": np.tile(used_bands["band"].to_numpy(), n_e),
        "label": used_bands["label"].to_list() * n_e,
        "centre_wavelength": np.tile(used_bands["centre_wavelength"].to_numpy(), n_e),
        "correlation": r.reshape(-1),
        "r2": (r**2).reshape(-1),
        "slope": slope.reshape(-1),
        "intercept": intercept.reshape(-1),
        "sites": count.reshape(-1).astype(np.int64),
    })
    texture_levels = pl.DataFrame({
        "site": [site for _ in range(n_e) for site in sites for _ in range(n_b)],
        "youngs_modulus": np.repeat(grid, len(sites) * n_b),
        "band": np.tile(used_bands["band"].to_numpy(), n_e * len(sites)),
        "label": used_bands["label"].to_list() * (n_e * len(sites)),
        "level_db": texture.reshape(-1),
    })
    noise_frame = pl.DataFrame({
        "site": [site for site, _ in noise], "band": [band for _, band in noise],
        "level_db": list(noise.values())}).filter(pl.col("band").is_in(band_ids))
    return CalibrationResult(
        best_modulus=float(grid[best]), interval=(low, high), confidence=confidence,
        at_grid_edge=best in (0, grid.size - 1), scores=scores, correlations=correlations,
        texture_levels=texture_levels, noise_levels=noise_frame, n_bootstrap=n_bootstrap,
    )
