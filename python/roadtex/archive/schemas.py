"""The bulk job's tables: manifest columns and the schema of every Parquet file it writes, with the
unit of every numeric column.

Each table is declared once as ``column: (type, unit)``; the job writes the units into each Parquet
file's key-value metadata under ``units`` (a JSON object from column to unit), so a file read years
later still says what its numbers mean. ``"1"`` marks a dimensionless share or ratio, ``"count"`` a
count; text and boolean columns have no unit.
"""

from __future__ import annotations

import json

import polars as pl

from roadtex.profiles.readers import READ_OPTIONS

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
#: Manifest columns that carry :func:`roadtex.read_profile` options for one run (``dx`` in m is
#: the sampling interval of a heights-only file); they override the job's reader defaults.
READER_COLUMNS: dict[str, type[pl.DataType]] = {
    name: {str: pl.String, float: pl.Float64, bool: pl.Boolean}[kind] for name, kind in READ_OPTIONS.items()
}
#: ``dy`` (m): the spacing across the road of a surface run's 2-D heights file (``dx`` is along it).
READER_COLUMNS["dy"] = pl.Float64
#: Metadata columns copied from the manifest into every segment row.
METADATA_COLUMNS = ("site", "lane", "wheel_path", "date", "device", "direction", "pavement", "speed_kmh")
#: Prefix of optional measured-noise columns: ``noise_<centre frequency in Hz>`` in dB, e.g.
#: ``noise_1000`` for the 1 kHz CPX one-third-octave band. Checked and carried in the manifest for
#: :func:`roadtex.calibrate_modulus` (join on ``run_id``); the bulk job does not use them.
NOISE_PREFIX = "noise_"

Columns = dict[str, tuple[pl.DataType, str | None]]

_METADATA: Columns = {name: ((pl.Float64(), "km/h") if name == "speed_kmh" else (pl.String(), None))
                      for name in METADATA_COLUMNS}

SEGMENT_COLUMNS: Columns = {
    "run_id": (pl.String(), None),
    "model": (pl.String(), None),                 # "line" (line model) or "areal" (surface runs' areal model)
    "segment": (pl.Int64(), "count"),             # segment of a line run; tile (along the road) of a surface run
    "line": (pl.Int64(), "count"),                # surface runs: row of the surface (null: line runs, areal tiles)
    "youngs_modulus": (pl.Float64(), "Pa"),
    "start": (pl.Float64(), "m"),                 # position of the segment's first point in the run
    "end": (pl.Float64(), "m"),                   # start + segment length
    **_METADATA,
    "mpd": (pl.Float64(), "m"),                   # mean of the valid ISO 13473-1 baselines inside; null if none
    "rms_height": (pl.Float64(), "m"),            # of the segment as solved
    "missing_fraction": (pl.Float64(), "1"),      # share of its samples with no reading (drop-outs, spikes and
                                                  # outliers removed), filled before solving
    "no_level_reason": (pl.String(), None),       # why it has no level (over 10 % missing: roadtex.profiles.coverage);
                                                  # its contact measures and band levels are then null; null: it has
    "contact_fraction": (pl.Float64(), "1"),      # share of the segment length in contact
    "mean_penetration": (pl.Float64(), "m"),      # mean of (highest point - rubber surface)
    "max_penetration": (pl.Float64(), "m"),       # deepest the rubber reaches below the highest point
    "mean_gap": (pl.Float64(), "m"),              # mean of (rubber surface - road): texture left unfilled
    "max_pressure": (pl.Float64(), "Pa"),
    "residual": (pl.Float64(), "1"),              # solver residual (relative, see roadtex.contact's tol)
    "iterations": (pl.Int64(), "count"),
    "converged": (pl.Boolean(), None),
}
BAND_COLUMNS: Columns = {
    "run_id": (pl.String(), None),
    "model": (pl.String(), None),                 # "line" (line model) or "areal" (surface runs' areal model)
    "segment": (pl.Int64(), "count"),             # segment of a line run; tile (along the road) of a surface run
    "line": (pl.Int64(), "count"),                # surface runs: row of the surface (null: line runs, areal tiles)
    "youngs_modulus": (pl.Float64(), "Pa"),
    "band": (pl.Int64(), "1"),                    # ISO band index n: centre 1000 / 10^(n/10) mm
    "label": (pl.String(), None),                 # nominal centre wavelength as acousticians write it (mm)
    "centre_wavelength": (pl.Float64(), "m"),     # exact
    "frequency": (pl.Float64(), "Hz"),            # at the run's speed (f = V / wavelength); null without a speed
    "reported": (pl.Boolean(), None),             # within the standard's limits for this dx and segment length, and
                                                  # its segment measured (levels null where segments.no_level_reason)
    "reason": (pl.String(), None),                # why a band is not reported (null when it is)
    "texture_level": (pl.Float64(), "dB re 1 um"),     # original profile segment
    "enveloped_level": (pl.Float64(), "dB re 1 um"),   # enveloped profile
    "pressure_level": (pl.Float64(), "dB re 1 Pa"),
    # What the run's sampling cannot tell of enveloped_level (line runs; roadtex.budget.sampling, calibrated on
    # the CAPTIF 0.0375 mm files; null outside the calibration: surface runs, other segment lengths or
    # pressures, octave bands, samplings coarser than 1 mm, bands outside 2.5 to 40 mm). Apart from level_error_db.
    "sampling_bias_db": (pl.Float64(), "dB"),         # expected enveloped_level (uncorrected) - the 0.0375 mm data's
    "sampling_correction_db": (pl.Float64(), "dB"),   # subtracted from enveloped_level (--sampling-correction; 0 where
                                                      # the bias is not systematic; null when not corrected)
    "sampling_uncertainty_db": (pl.Float64(), "dB"),  # half-width about this row's enveloped_level (one segment) holding
                                                      # the 0.0375 mm data's level (about 95 %)
    "sampling_run_uncertainty_db": (pl.Float64(), "dB"),  # the same for the run's mean level over its segments
    "sampling_note": (pl.String(), None),         # why this row's sampling figures are null, or why a correction
                                                  # asked for was not made (line runs; null when stated as asked)
    "level_error_db": (pl.Float64(), "dB"),       # upper estimate of the numerical error of this row's levels
                                                  # (line runs: their group's pilot, times 10^(d / 20) for a row
                                                  # whose level lies d dB below its group's median of that band
                                                  # and modulus; surface runs: their own areal pilot, per model;
                                                  # null without budget)
    "interpolant_spread_db": (pl.Float64(), "dB"),  # what the data's sampling cannot tell: the largest difference of
                                                  # the converged levels between interpolants of the readings
                                                  # (linear, monotone cubic, band-limited); null where not measured
    "sampling_limited": (pl.Boolean(), None),     # interpolant_spread_db above the budget: the data's resolution,
                                                  # not the solver, limits this band's contact levels
}
RUN_COLUMNS: Columns = {
    "run_id": (pl.String(), None),
    "path": (pl.String(), None),
    "format": (pl.String(), None),                # as given in the manifest (null: guessed from the file)
    "file_dx": (pl.Float64(), "m"),               # the file's own nominal sampling interval
    "dx_used": (pl.Float64(), "m"),               # the interval the run's readings were solved at: file_dx, or coarser
                                                  # where its group's pilot averaged them down (never finer)
    "tol_used": (pl.Float64(), "1"),              # the solver tolerance it was solved at (its plan's; a surface run's own pilot's choice)
    "refine": (pl.Int64(), "1"),                  # k: the contact model's grid is k times finer than dx_used (along
                                                  # the road), the readings joined (roadtex.models.grid)
    "refine_across": (pl.Int64(), "1"),           # ... and across it (surface runs; null: line runs)
    "model_dx": (pl.Float64(), "m"),              # the model grid's spacing along the road, dx_used / refine
    "model_dy": (pl.Float64(), "m"),              # ... and across it (surface runs; null: line runs)
    "points": (pl.Int64(), "count"),              # after conditioning
    "raw_length": (pl.Float64(), "m"),            # as read
    "trimmed_length": (pl.Float64(), "m"),        # cut away as reference plates (and beyond them)
    "length": (pl.Float64(), "m"),                # after conditioning
    "plates": (pl.String(), None),                # where reference plates were found ("none")
    "dropout_fraction": (pl.Float64(), "1"),      # readings missing in the file, after trimming
    "spike_fraction": (pl.Float64(), "1"),        # readings removed as spikes (then interpolated)
    "outlier_fraction": (pl.Float64(), "1"),      # readings removed as gross outliers (drop-out codes)
    "conditioning_warnings": (pl.String(), None),  # what exceeded the warning thresholds (null: nothing)
    "segments": (pl.Int64(), "count"),
    "sampling_dx": (pl.Float64(), "m"),           # the sampling the contact levels' sampling statement is for: the
                                                  # coarser of file_dx and dx_used (null: no statement, see bands)
    "contact_resolved_to": (pl.Float64(), "m"),   # shortest band centre wavelength down to which every band has a
                                                  # run-mean sampling uncertainty <= 1 dB (null: none, or no statement)
    "mpd": (pl.Float64(), "m"),                   # ISO 13473-1 over the whole run; null without a valid baseline
    "mpd_valid": (pl.Boolean(), None),            # ISO validity: at least half the baselines valid
    "mpd_valid_baselines": (pl.Int64(), "count"),
    "mpd_baselines": (pl.Int64(), "count"),
    "mpd_spike_rejected": (pl.Int64(), "count"),  # baselines rejected by ISO 13473-1's spike criterion (> 5 %)
    "mpd_dropout_rejected": (pl.Int64(), "count"),  # ... by its drop-out criterion (> 10 %); a baseline may fail both
    "mpd_rejections": (pl.String(), None),        # why, in words, with the failing shares (null: none rejected)
    "worst_level_error_db": (pl.Float64(), "dB"),  # estimated, in the tyre/road noise bands, for a level at its
                                                   # group's median (line runs; bands.parquet states more for
                                                   # levels below it); null without budget (surface runs: both
                                                   # models, from their areal pilot)
    "within_budget": (pl.Boolean(), None),        # null without budget
    "speedup": (pl.Float64(), "1"),               # finest setting's solver work / this one's (the pilots' count;
                                                  # surface runs: the reference tol, 1e-6 (1e-10 until
                                                  # 0.5.4), against the job's, same spacings)
    "time_saved_fraction": (pl.Float64(), "1"),   # share of the finest setting's solve time saved (1 - 1/speedup)
    "error_source": (pl.String(), None),          # where the stated errors come from: its group's pilot, or (no pilot
                                                  # of its group and sampling) the largest of any group; null: no budget
}
PILOT_COLUMNS: Columns = {
    "group": (pl.String(), None),                 # device / pavement group of runs sharing one pilot
    "dx": (pl.Float64(), "m"),                    # the data's interval
    "points": (pl.Int64(), "count"),              # per segment, at dx
    "refine": (pl.Int64(), "1"),                  # k: the model grid is dx / k
    "model_dx": (pl.Float64(), "m"),
    "tol": (pl.Float64(), "1"),
    "reference": (pl.Boolean(), None),            # the finest setting the others are measured against
    "chosen": (pl.Boolean(), None),               # the group's choice
    "band": (pl.Int64(), "1"),
    "label": (pl.String(), None),
    "centre_wavelength": (pl.Float64(), "m"),
    "in_budget": (pl.Boolean(), None),            # a tyre/road noise band the budget applies to
    "seconds_per_metre": (pl.Float64(), "s/m"),   # solve time, every modulus, per metre of road
    "work_per_metre": (pl.Float64(), "1/m"),      # iterations x N log2 N of those solves per metre
    "texture_error_db": (pl.Float64(), "dB"),
    "enveloped_error_db": (pl.Float64(), "dB"),
    "pressure_error_db": (pl.Float64(), "dB"),
    "level_error_db": (pl.Float64(), "dB"),
    "pilot_segments": (pl.Int64(), "count"),
    "richardson": (pl.String(), None),            # how the reference's own error was judged (one halving / not converging: factor 4)
    "choosable": (pl.Boolean(), None),            # a setting a job can run (False: a reference on a grid of its own)
}
ERROR_COLUMNS: Columns = {
    "run_id": (pl.String(), None),
    "path": (pl.String(), None),
    "stage": (pl.String(), None),                 # read, condition, mpd, segment, spectra, solve
    "error_type": (pl.String(), None),
    "message": (pl.String(), None),
}
SURFACE_ERROR_COLUMNS: Columns = {                # per surface run (runs/<id>/level_errors.parquet)
    "run_id": (pl.String(), None),
    "model": (pl.String(), None),                 # "line" or "areal"
    "band": (pl.Int64(), "1"),
    "in_budget": (pl.Boolean(), None),            # a tyre/road noise band the budget applies to
    "level_error_db": (pl.Float64(), "dB"),       # upper estimate of the numerical error of the model's levels
    "speedup": (pl.Float64(), "1"),               # solver work at the reference tol (1e-6; 1e-10 until
                                                  # 0.5.4) / at the job's tol (both models)
    "pilot_tiles": (pl.Int64(), "count"),         # tiles the areal pilot solved
    "refine_along": (pl.Int64(), "count"),        # the model grid's k along the road the estimate is for
    "refine_across": (pl.Int64(), "count"),       # ... and across it
}
PROFILE_COLUMNS: Columns = {
    "run_id": (pl.String(), None),
    "youngs_modulus": (pl.Float64(), "Pa"),
    "position": (pl.Float64(), "m"),
    "height": (pl.Float64(), "m"),                # conditioned road profile
    "envelope": (pl.Float64(), "m"),              # stitched enveloped profile
    "pressure": (pl.Float64(), "Pa"),             # stitched contact pressure (the mean over each reading's interval)
}
EXAMPLE_COLUMNS: Columns = {
    "run_id": (pl.String(), None),
    "segment": (pl.Int64(), "count"),             # the run's middle segment
    "youngs_modulus": (pl.Float64(), "Pa"),
    "dx": (pl.Float64(), "m"),
    "position": (pl.Float64(), "m"),              # along the run
    "height": (pl.Float64(), "m"),                # the segment as solved (its line removed)
    "envelope": (pl.Float64(), "m"),              # enveloped profile
    "pressure": (pl.Float64(), "Pa"),             # contact pressure
}
SURFACE_EXAMPLE_COLUMNS: Columns = {
    "run_id": (pl.String(), None),
    "segment": (pl.Int64(), "count"),             # the surface run's middle tile
    "youngs_modulus": (pl.Float64(), "Pa"),       # the job's middle modulus
    "dx": (pl.Float64(), "m"),                    # along the road
    "dy": (pl.Float64(), "m"),                    # across the road
    "x": (pl.Float64(), "m"),                     # along the run
    "y": (pl.Float64(), "m"),                     # across the surface
    "height": (pl.Float64(), "m"),                # the tile as solved (its plane removed)
    "envelope": (pl.Float64(), "m"),              # enveloped surface (areal model)
    "pressure": (pl.Float64(), "Pa"),             # contact pressure (areal model; the mean over each reading's cell)
}
VON_MEIER_COLUMNS: Columns = {
    "run_id": (pl.String(), None),
    "segment": (pl.Int64(), "count"),             # the run's example segment (examples.parquet)
    "d_star": (pl.Float64(), "1/m"),              # von Meier curvature limit
    "index": (pl.Int64(), "count"),               # sample within the segment
    "x": (pl.Float64(), "m"),                     # index x dx, from the segment's start
    "height": (pl.Float64(), "m"),                # the segment as solved (examples.parquet's height)
    "envelope": (pl.Float64(), "m"),              # von Meier envelope
    "depth": (pl.Float64(), "m"),                 # envelope - height
}
PENETRATION_COLUMNS: Columns = {
    "run_id": (pl.String(), None),
    "segment": (pl.Int64(), "count"),             # the run's example segment (examples.parquet)
    "valley": (pl.Int64(), "count"),              # valleys of the von Meier envelope at d_star, left to right
    "start": (pl.Int64(), "count"),               # sample of the bounding asperity on the left
    "end": (pl.Int64(), "count"),                 # ... and on the right
    "x_start": (pl.Float64(), "m"),
    "x_end": (pl.Float64(), "m"),
    "x_deepest": (pl.Float64(), "m"),
    "width": (pl.Float64(), "m"),
    "depth": (pl.Float64(), "m"),                 # below the line joining the two asperities
    "d_star": (pl.Float64(), "1/m"),
    "von_meier_penetration": (pl.Float64(), "m"),
    "youngs_modulus": (pl.Float64(), "Pa"),
    "mean_pressure": (pl.Float64(), "Pa"),
    "inrets_penetration": (pl.Float64(), "m"),    # the job's own solve (examples.parquet's envelope)
    "von_meier_ratio": (pl.Float64(), "1"),       # penetration clipped to [0, depth] over depth
    "inrets_ratio": (pl.Float64(), "1"),
}
EDGE_EFFECT_COLUMNS: Columns = {
    "model": (pl.String(), None),                 # "finite", "periodic" or "flat punch (exact)"
    "index": (pl.Int64(), "count"),               # element
    "x": (pl.Float64(), "m"),                     # element centre
    "pressure": (pl.Float64(), "Pa"),
    "pressure_ratio": (pl.Float64(), "1"),        # p / P
    "youngs_modulus": (pl.Float64(), "Pa"),
    "mean_pressure": (pl.Float64(), "Pa"),
}

SECTION_COLUMNS: Columns = {                      # line runs, one row per run and section (roadtex.archive.sections)
    "run_id": (pl.String(), None),
    "section": (pl.Int64(), "count"),             # 0, 1, ... along the run
    "start": (pl.Float64(), "m"),                 # chainage as the file gives it (its own distances)
    "end": (pl.Float64(), "m"),
    "length": (pl.Float64(), "m"),                # end - start: the section length, less in a partial section
    "partial": (pl.Boolean(), None),              # shorter than the job's section_length
    "note": (pl.String(), None),                  # why it is partial (run shorter than a section, its last part)
    "baselines": (pl.Int64(), "count"),           # ISO 13473-1 100 mm baselines starting in the section
    "valid_baselines": (pl.Int64(), "count"),
    "valid_baseline_fraction": (pl.Float64(), "1"),
    "mpd": (pl.Float64(), "m"),                   # mean MSD of the valid baselines; null if none
    "mpd_valid": (pl.Boolean(), None),            # at least half the baselines valid (ISO 13473-1)
    "etd": (pl.Float64(), "m"),                   # estimated texture depth after etd_edition
    "etd_edition": (pl.String(), None),           # ISO 13473-1 edition of the ETD transformation ("2019", "1997")
    "rq": (pl.Float64(), "m"),                    # RMS height of the texture profile (valid baselines, lines removed)
    "rsk": (pl.Float64(), "1"),                   # skewness
    "rku": (pl.Float64(), "1"),                   # kurtosis (3 for Gaussian heights)
    "dropout_fraction": (pl.Float64(), "1"),      # raw readings missing, mean over the baselines
    "spike_fraction": (pl.Float64(), "1"),        # samples flagged as spikes, mean over the baselines
}
SECTION_BAND_COLUMNS: Columns = {                 # line runs, per section, E and band (join sections on run_id, section)
    "run_id": (pl.String(), None),
    "section": (pl.Int64(), "count"),
    "start": (pl.Float64(), "m"),
    "end": (pl.Float64(), "m"),
    "youngs_modulus": (pl.Float64(), "Pa"),
    "band": (pl.Int64(), "1"),
    "label": (pl.String(), None),
    "centre_wavelength": (pl.Float64(), "m"),
    "reported": (pl.Boolean(), None),             # as in bands.parquet
    "segments": (pl.Int64(), "count"),            # contact segments starting in the section
    "texture_level": (pl.Float64(), "dB re 1 um"),     # energy average of the segments' levels
    "enveloped_level": (pl.Float64(), "dB re 1 um"),
    "pressure_level": (pl.Float64(), "dB re 1 Pa"),
}

AREAL_COLUMNS: Columns = {                        # surface runs: ISO 25178-2 parameters (roadtex.surfaces.areal)
    "run_id": (pl.String(), None),
    "scope": (pl.String(), None),                 # "run" (the conditioned surface) or "tile" (as solved)
    "tile": (pl.Int64(), "count"),                # null for the run's row
    "start": (pl.Float64(), "m"),                 # along the road
    "end": (pl.Float64(), "m"),
    "width": (pl.Float64(), "m"),                 # across the road
    "sa": (pl.Float64(), "m"),
    "sq": (pl.Float64(), "m"),
    "ssk": (pl.Float64(), "1"),                   # null on a flat area
    "sku": (pl.Float64(), "1"),
    "sp": (pl.Float64(), "m"),
    "sv": (pl.Float64(), "m"),                    # |lowest height|
    "sz": (pl.Float64(), "m"),
    "sdq": (pl.Float64(), "1"),                   # RMS gradient
    "sdr": (pl.Float64(), "1"),                   # developed interfacial area ratio (0.01 is 1 %)
    "filters": (pl.String(), None),               # the F-operation and S-/L-filters applied
}


def schema(columns: Columns) -> dict[str, pl.DataType]:
    """The polars schema of a table declared as ``column: (type, unit)``."""
    return {name: dtype for name, (dtype, _) in columns.items()}


def units(columns: Columns) -> dict[str, str]:
    """Column -> unit of the numeric columns of a table declared as ``column: (type, unit)``."""
    return {name: unit for name, (_, unit) in columns.items() if unit is not None}


def parquet_metadata(columns: Columns) -> dict[str, str]:
    """The key-value metadata every Parquet file of the job carries: ``units`` as JSON."""
    return {"units": json.dumps(units(columns), sort_keys=True)}


SEGMENT_SCHEMA = schema(SEGMENT_COLUMNS)
BAND_SCHEMA = schema(BAND_COLUMNS)
RUN_SCHEMA = schema(RUN_COLUMNS)
ERROR_SCHEMA = schema(ERROR_COLUMNS)
PROFILE_SCHEMA = schema(PROFILE_COLUMNS)
EXAMPLE_SCHEMA = schema(EXAMPLE_COLUMNS)
EDGE_EFFECT_SCHEMA = schema(EDGE_EFFECT_COLUMNS)
SURFACE_EXAMPLE_SCHEMA = schema(SURFACE_EXAMPLE_COLUMNS)
VON_MEIER_SCHEMA = schema(VON_MEIER_COLUMNS)
PENETRATION_SCHEMA = schema(PENETRATION_COLUMNS)
PILOT_SCHEMA = schema(PILOT_COLUMNS)
SURFACE_ERROR_SCHEMA = schema(SURFACE_ERROR_COLUMNS)
SECTION_SCHEMA = schema(SECTION_COLUMNS)
AREAL_SCHEMA = schema(AREAL_COLUMNS)
SECTION_BAND_SCHEMA = schema(SECTION_BAND_COLUMNS)
#: Columns the job adds when it combines the per-run tables: what the plan says (its error
#: estimates and timings), which must not make a run's own tables stale when the plan is redone.
#: The band columns of the sampling statement (null until a line run's own is joined, and for surface runs).
SAMPLING_BAND_COLUMNS = ("sampling_bias_db", "sampling_correction_db", "sampling_uncertainty_db",
                         "sampling_run_uncertainty_db", "sampling_note")
PLAN_BAND_COLUMNS = ("level_error_db", "interpolant_spread_db", "sampling_limited")
PLAN_RUN_COLUMNS = ("worst_level_error_db", "within_budget", "speedup", "time_saved_fraction", "error_source")
RUN_BAND_SCHEMA = {k: v for k, v in BAND_SCHEMA.items() if k not in PLAN_BAND_COLUMNS}
RUN_RUN_SCHEMA = {k: v for k, v in RUN_SCHEMA.items() if k not in PLAN_RUN_COLUMNS}
#: Each table the job writes, by file stem, with its declaration.
TABLES: dict[str, Columns] = {
    "segments": SEGMENT_COLUMNS, "bands": BAND_COLUMNS, "runs": RUN_COLUMNS, "errors": ERROR_COLUMNS,
    "profiles": PROFILE_COLUMNS, "examples": EXAMPLE_COLUMNS, "edge_effect": EDGE_EFFECT_COLUMNS,
    "pilot": PILOT_COLUMNS, "surface_examples": SURFACE_EXAMPLE_COLUMNS, "von_meier": VON_MEIER_COLUMNS,
    "penetration": PENETRATION_COLUMNS,
}
TABLES.update({"sections": SECTION_COLUMNS, "section_bands": SECTION_BAND_COLUMNS, "areal": AREAL_COLUMNS})
