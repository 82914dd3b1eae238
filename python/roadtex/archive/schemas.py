"""The bulk job's tables: manifest columns and the schema of every Parquet file it writes."""

from __future__ import annotations

import polars as pl

#: Manifest columns that carry run metadata, with their types. ``path`` is the only required column.
MANIFEST_COLUMNS: dict[str, type[pl.DataType] | pl.DataType] = {
    "path": pl.String,
    "run_id": pl.String,
    "format": pl.String,
    "site": pl.String,
    "lane": pl.String,
    "wheel_path": pl.String,
    "date": pl.String,
    "device": pl.String,
    "direction": pl.String,
    "pavement": pl.String,
    "speed_kmh": pl.Float64,
}
#: Metadata columns copied from the manifest into every segment row.
METADATA_COLUMNS = ("site", "lane", "wheel_path", "date", "device", "direction", "pavement", "speed_kmh")
#: Prefix of optional measured-noise columns: ``noise_<centre frequency in Hz>`` in dB, e.g.
#: ``noise_1000`` for the 1 kHz CPX one-third-octave band. Checked and carried in the manifest for
#: :func:`roadtex.calibrate_modulus` (join on ``run_id``); the bulk job does not use them.
NOISE_PREFIX = "noise_"

SEGMENT_SCHEMA: dict[str, pl.DataType] = {
    "run_id": pl.String(),
    "segment": pl.Int64(),
    "youngs_modulus": pl.Float64(),      # Pa
    "start": pl.Float64(),               # m, position of the segment's first point in the run
    "end": pl.Float64(),                 # m, start + segment length
    **{name: (pl.Float64() if name == "speed_kmh" else pl.String()) for name in METADATA_COLUMNS},
    "mpd": pl.Float64(),                 # m, mean of the valid ISO 13473-1 baselines inside the segment
    "rms_height": pl.Float64(),          # m, of the segment as solved
    "contact_fraction": pl.Float64(),    # share of the segment length in contact (0..1)
    "mean_penetration": pl.Float64(),    # m, mean of (highest point - rubber surface)
    "max_penetration": pl.Float64(),     # m, deepest the rubber reaches below the highest point
    "mean_gap": pl.Float64(),            # m, mean of (rubber surface - road): texture left unfilled
    "max_pressure": pl.Float64(),        # Pa
    "residual": pl.Float64(),            # solver residual (relative, see roadtex.contact's tol)
    "iterations": pl.Int64(),
    "converged": pl.Boolean(),
}
BAND_SCHEMA: dict[str, pl.DataType] = {
    "run_id": pl.String(),
    "segment": pl.Int64(),
    "youngs_modulus": pl.Float64(),      # Pa
    "band": pl.Int64(),                  # ISO band index n: centre 1000 / 10^(n/10) mm
    "label": pl.String(),                # nominal centre wavelength as acousticians write it (mm)
    "centre_wavelength": pl.Float64(),   # m, exact
    "frequency": pl.Float64(),           # Hz at the run's speed (f = V / wavelength); null without a speed
    "texture_level": pl.Float64(),       # dB re 1 um, original profile segment
    "enveloped_level": pl.Float64(),     # dB re 1 um, enveloped profile
    "pressure_level": pl.Float64(),      # dB re roadtex.spectra.REFERENCE_PRESSURE
}
RUN_SCHEMA: dict[str, pl.DataType] = {
    "run_id": pl.String(),
    "path": pl.String(),
    "format": pl.String(),               # as given in the manifest (null: guessed from the file)
    "points": pl.Int64(),                # after conditioning
    "length": pl.Float64(),              # m, after conditioning
    "dx": pl.Float64(),                  # m
    "segments": pl.Int64(),
    "mpd": pl.Float64(),                 # m, ISO 13473-1 over the whole run
    "dropout_fraction": pl.Float64(),    # of the raw profile
}
ERROR_SCHEMA: dict[str, pl.DataType] = {
    "run_id": pl.String(),
    "path": pl.String(),
    "stage": pl.String(),                # read, condition, mpd, segment, spectra, solve
    "error_type": pl.String(),
    "message": pl.String(),
}
PROFILE_SCHEMA: dict[str, pl.DataType] = {
    "run_id": pl.String(),
    "youngs_modulus": pl.Float64(),      # Pa
    "position": pl.Float64(),            # m
    "height": pl.Float64(),              # m, conditioned road profile
    "envelope": pl.Float64(),            # m, stitched enveloped profile
    "pressure": pl.Float64(),            # Pa, stitched contact pressure
}
EXAMPLE_SCHEMA: dict[str, pl.DataType] = {
    "run_id": pl.String(),
    "segment": pl.Int64(),               # the run's middle segment
    "youngs_modulus": pl.Float64(),      # Pa
    "dx": pl.Float64(),                  # m
    "position": pl.Float64(),            # m, along the run
    "height": pl.Float64(),              # m, the segment as solved (its line removed)
    "envelope": pl.Float64(),            # m, enveloped profile
    "pressure": pl.Float64(),            # Pa, contact pressure
}
EDGE_EFFECT_SCHEMA: dict[str, pl.DataType] = {
    "model": pl.String(),                # "finite", "periodic" or "flat punch (exact)"
    "index": pl.Int64(),                 # element
    "x": pl.Float64(),                   # m, element centre
    "pressure": pl.Float64(),            # Pa
    "pressure_ratio": pl.Float64(),      # p / P
    "youngs_modulus": pl.Float64(),      # Pa
    "mean_pressure": pl.Float64(),       # Pa
}
