"""Bulk reprocessing of road-survey archives: a manifest in, Parquet tables out.

The job reads, conditions and segments each run (one profile file), solves the periodic contact
problem for every segment and every requested Young's modulus in the Rust core, computes band
levels and mean profile depth, and writes tables (schemas below). It is built to be left alone:

- **Per-run atomic outputs.** Each run's tables go to ``OUT/runs/<run_id>/``. Every file is written
  to a temporary name and renamed into place; the run's ``status.json`` is renamed in last, so a
  run counts as done only when all its files are complete. A job killed at any moment (SIGKILL
  included) loses at most the runs in flight.
- **Resume and change detection.** ``status.json`` records a fingerprint of the processing options
  and the SHA-256 of the input file. A re-run skips every run whose fingerprint still matches and
  recomputes the others (changed options, changed or new files). Results do not depend on the
  thread count, the engine or the order in which runs finish, so a resumed job ends with tables
  identical to an uninterrupted one.
- **Bad runs.** A run that cannot be read or solved is recorded (``errors.parquet``) and the job
  goes on. Failures to *write* output (unwritable folder, full disk) stop the job with a clear
  :class:`ArchiveWriteError`; what was already written stays intact.
- **Bounded memory.** Runs are streamed one at a time (or one per Dask worker) and long runs are
  solved in chunks of segments.

Combined tables in ``OUT`` (rewritten atomically at the end of every job, in manifest order):

``segments.parquet`` — one row per (run, segment, modulus), :data:`SEGMENT_SCHEMA`.
``bands.parquet`` — one row per (run, segment, modulus, band), :data:`BAND_SCHEMA`.
``errors.parquet`` — one row per failed run, :data:`ERROR_SCHEMA`.
``runs.parquet`` — one row per processed run (points, length, MPD of the whole run), :data:`RUN_SCHEMA`.
``parameters.json`` — the options, their fingerprint, and the software versions.
Profiles (``keep_profiles=True``): ``OUT/runs/<run_id>/profiles.parquet`` per run, schema
:data:`PROFILE_SCHEMA`; :func:`read_profiles` reads them back by run and position.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import os
import platform
import shutil
import sys
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Literal, Sequence

import numpy as np
import polars as pl

log = logging.getLogger("roadtex.archive")

Engine = Literal["local", "dask"]

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

_STATUS = "status.json"
_PROFILE_SUFFIXES = {".dat", ".csv", ".tsv", ".txt", ".npy", ".parquet"}
#: Segments solved per call of the Rust core; bounds memory on long runs.
_CHUNK_SEGMENTS = 2048


class ManifestError(ValueError):
    """The manifest is unreadable or has unknown, missing or inconsistent columns."""


class ArchiveWriteError(OSError):
    """Output could not be written (unwritable folder, full disk): the job stops, nothing is corrupted."""


@dataclass(frozen=True)
class ProcessingOptions:
    """What the bulk job computes. All values SI.

    Attributes:
        youngs_moduli: rubber moduli E to solve for (Pa).
        mean_pressure: P, mean contact pressure (Pa).
        poisson: nu of the rubber.
        segment_length: length of the segments handed to the periodic contact model (m).
        segment_overlap: overlap between consecutive segments (m).
        dx: resample every run to this sampling interval (m); None keeps the file's sampling.
        spike_alpha: spike criterion alpha of the conditioning for the contact model (None: no
            spike removal). It compares adjacent samples, so it means what ISO 13473-1 means
            only at 0.5 to 1 mm sampling; at finer sampling leave it off or raise it.
        mpd_spike_alpha: spike criterion of the mean profile depth, computed after ISO 13473-1 on
            the profile resampled to 0.5 mm (3 in the standard; the CAPTIF authors use 6 on
            coarse chip seals; None skips).
        tol: solver tolerance (relative residual, see :func:`roadtex.contact`). 1e-6 of a few
            millimetres of texture is a few nanometres, far below what the spectra resolve.
            Each segment's moduli are solved in the order given, each from the previous one's
            solution (``contact_many(warm_start=True)``): every result meets ``tol``.
        max_iterations: solver iteration cap; segments that do not converge are kept and flagged.
        band_kind: "third_octave" or "octave".
        speed_kmh: vehicle speed for the band frequencies when the manifest has no ``speed_kmh``.
        keep_profiles: also write the enveloped profiles and pressures (large).
    """

    youngs_moduli: tuple[float, ...] = (1e6, 2e6, 5e6, 1e7)
    mean_pressure: float = 2e5
    poisson: float = 0.5
    segment_length: float = 0.5
    segment_overlap: float = 0.0
    dx: float | None = None
    spike_alpha: float | None = None
    mpd_spike_alpha: float | None = 3.0
    tol: float = 1e-6
    max_iterations: int = 2000
    band_kind: str = "third_octave"
    speed_kmh: float | None = None
    keep_profiles: bool = False

    def __post_init__(self) -> None:
        moduli = tuple(float(e) for e in np.atleast_1d(self.youngs_moduli))
        object.__setattr__(self, "youngs_moduli", moduli)
        if not moduli or not all(np.isfinite(e) and e > 0 for e in moduli):
            raise ValueError(f"youngs_moduli must be positive finite values in Pa, got {moduli}")
        for name in ("mean_pressure", "segment_length", "tol"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive finite number, got {value!r}")
        if self.dx is not None and not (np.isfinite(self.dx) and self.dx > 0):
            raise ValueError(f"dx must be positive (m) or None, got {self.dx!r}")
        if not (0 <= self.segment_overlap < self.segment_length):
            raise ValueError(f"segment_overlap must be in [0, segment_length), got {self.segment_overlap!r}")
        if not (np.isfinite(self.poisson) and -1.0 < self.poisson <= 0.5):
            raise ValueError(f"poisson must lie in (-1, 0.5], got {self.poisson!r}")
        if isinstance(self.max_iterations, bool) or not isinstance(self.max_iterations, (int, np.integer)) \
                or self.max_iterations < 1:
            raise ValueError(f"max_iterations must be a whole number >= 1, got {self.max_iterations!r}")
        for name in ("spike_alpha", "mpd_spike_alpha", "speed_kmh"):
            value = getattr(self, name)
            if value is not None and not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be positive or None, got {value!r}")
        if self.band_kind not in ("third_octave", "octave"):
            raise ValueError(f"band_kind must be 'third_octave' or 'octave', got {self.band_kind!r}")

    def fingerprint(self) -> str:
        """SHA-256 of the options and the roadtex version: equal fingerprints give equal results."""
        from roadtex import __version__

        payload = json.dumps({"options": dataclasses.asdict(self), "roadtex": __version__}, sort_keys=True)
        return hashlib.sha256(payload.encode()).hexdigest()


@dataclass(frozen=True)
class ProcessSummary:
    """What a :func:`process` call did."""

    out_dir: Path
    runs: int
    processed: int
    skipped: int
    failed: int
    kilometres: float
    seconds: float
    tables: dict[str, Path] = field(default_factory=dict)

    def __str__(self) -> str:
        return (f"{self.runs} runs: {self.processed} processed, {self.skipped} already done, "
                f"{self.failed} failed; {self.kilometres:.3f} km of profile in {self.seconds:.1f} s -> {self.out_dir}")


# --------------------------------------------------------------------------------------------
# Manifest
# --------------------------------------------------------------------------------------------

def read_manifest(source: str | os.PathLike[str] | pl.DataFrame, *, base_dir: str | os.PathLike[str] | None = None,
                  extra_columns: Sequence[str] = ()) -> pl.DataFrame:
    """Reads and checks a manifest (CSV or Parquet, or a DataFrame), before any work starts.

    Columns: ``path`` (required; relative paths are taken from the manifest's folder or
    ``base_dir``), optional ``run_id`` (default: the file name without suffix; must be unique),
    ``format`` (as for :func:`roadtex.read_profile`; default: guessed), the metadata columns
    :data:`METADATA_COLUMNS` (``speed_kmh`` in km/h) and measured noise levels ``noise_<band>``
    (dB). Any other column must be named in ``extra_columns`` (it is then carried along unused).

    Returns:
        The manifest with absolute paths, every known column present (null when absent) and
        ``run_id`` filled.

    Raises:
        ManifestError: unreadable file, missing ``path`` column, unknown columns, empty
            manifest, duplicate run ids, or a listed file that does not exist.
    """
    if isinstance(source, pl.DataFrame):
        table = source
        base = Path(base_dir) if base_dir is not None else Path.cwd()
    else:
        manifest_path = Path(source)
        base = Path(base_dir) if base_dir is not None else manifest_path.resolve().parent
        if not manifest_path.is_file():
            raise ManifestError(f"manifest {manifest_path} does not exist or is not a file")
        try:
            if manifest_path.suffix.lower() == ".parquet":
                table = pl.read_parquet(manifest_path)
            else:
                separator = "\t" if manifest_path.suffix.lower() in (".tsv", ".tab") else ","
                table = pl.read_csv(manifest_path, separator=separator, infer_schema=False)
        except Exception as exc:  # polars raises several exception types for malformed files
            raise ManifestError(f"cannot read manifest {manifest_path}: {exc}") from None
    if "path" not in table.columns:
        raise ManifestError(f"manifest has no 'path' column (columns: {', '.join(table.columns) or 'none'})")
    unknown = [c for c in table.columns
               if c not in MANIFEST_COLUMNS and not c.startswith(NOISE_PREFIX) and c not in extra_columns]
    if unknown:
        raise ManifestError(
            f"manifest has unknown column(s) {', '.join(map(repr, unknown))}; known: "
            f"{', '.join(MANIFEST_COLUMNS)}, and {NOISE_PREFIX}<band> for noise levels (dB); "
            "pass extra_columns to carry others along")
    if table.height == 0:
        raise ManifestError("manifest lists no runs")
    casts = []
    for name, dtype in MANIFEST_COLUMNS.items():
        if name not in table.columns:
            casts.append(pl.lit(None, dtype=dtype).alias(name))
        else:
            casts.append(pl.col(name).cast(dtype, strict=False).alias(name))
    for name in table.columns:
        if name.startswith(NOISE_PREFIX):
            casts.append(pl.col(name).cast(pl.Float64, strict=False).alias(name))
    for name in ("speed_kmh", *[c for c in table.columns if c.startswith(NOISE_PREFIX)]):
        if name in table.columns:
            bad = table.filter(pl.col(name).is_not_null()
                               & pl.col(name).cast(pl.Float64, strict=False).is_null())
            if bad.height:
                raise ManifestError(f"manifest column {name!r} must be numeric; row value {bad[name][0]!r}")
    if "speed_kmh" in table.columns:
        speeds = table["speed_kmh"].cast(pl.Float64, strict=False).drop_nulls()
        if speeds.len() and not (speeds > 0).all():
            raise ManifestError(f"manifest column 'speed_kmh' must be positive (km/h); found {speeds.filter(speeds <= 0)[0]!r}")
    table = table.with_columns(casts)
    if table["path"].null_count():
        raise ManifestError("manifest column 'path' has empty entries")
    paths = [str((base / p).resolve()) if not Path(p).is_absolute() else str(Path(p)) for p in table["path"]]
    missing = [p for p in paths if not Path(p).exists()]
    if missing:
        raise ManifestError(f"{len(missing)} file(s) listed in the manifest do not exist, first: {missing[0]}")
    run_ids = [rid if rid else Path(p).stem for rid, p in zip(table["run_id"].to_list(), paths)]
    seen: set[str] = set()
    for rid in run_ids:
        if rid in seen:
            raise ManifestError(f"run id {rid!r} appears twice in the manifest; give each run a unique run_id")
        if not rid or "/" in rid or "\\" in rid or rid in (".", ".."):
            raise ManifestError(f"run id {rid!r} cannot name an output folder")
        seen.add(rid)
    return table.with_columns(pl.Series("path", paths), pl.Series("run_id", run_ids))


def build_manifest(folder: str | os.PathLike[str], *, recursive: bool = True, read_metadata: bool = True) -> pl.DataFrame:
    """Lists the profile files of a folder as a manifest (one run per file, sorted by path).

    Files with suffix .dat (CAPTIF), .csv, .tsv, .txt, .npy or .parquet are listed, except
    hidden files and files named ``manifest*`` (a manifest kept beside its data). With
    ``read_metadata`` each file is read and the metadata it carries (site, wheel path, date,
    device, direction) fills the manifest columns; a file that cannot be read is still listed,
    so the job records why it fails.

    Returns:
        A manifest DataFrame with absolute paths; save it with ``write_csv`` and edit it freely.
    """
    from roadtex.profile import read_profile

    root = Path(folder)
    if not root.is_dir():
        raise ManifestError(f"{root} is not a folder")
    files = sorted(p for p in (root.rglob("*") if recursive else root.glob("*"))
                   if p.is_file() and p.suffix.lower() in _PROFILE_SUFFIXES
                   and not p.name.lower().startswith("manifest") and not p.name.startswith("."))
    if not files:
        raise ManifestError(f"no profile files (.dat, .csv, .tsv, .txt, .npy, .parquet) in {root}")
    rows = []
    for path in files:
        row: dict[str, Any] = {"path": str(path.resolve()), "run_id": _unique_run_id(path, root, rows)}
        if read_metadata:
            try:
                metadata = read_profile(path).metadata
            except Exception:  # listed anyway: the job records why it fails
                metadata = {}
            for name in METADATA_COLUMNS:
                if name in metadata and metadata[name] is not None:
                    row[name] = metadata[name]
        rows.append(row)
    table = pl.DataFrame(rows, infer_schema_length=None)
    return read_manifest(table, base_dir=root)


#: The seed's three pavements, the built-in demo archive.
DEMO_PAVEMENTS = ("cement_concrete", "dense_asphalt", "porous_asphalt")


def write_synthetic_archive(folder: str | os.PathLike[str], *, kinds: Sequence[str] = DEMO_PAVEMENTS,
                            runs_per_kind: int = 2, run_length: float = 4.0, dx: float = 5e-4,
                            file_format: str = "parquet", speed_kmh: float = 80.0, seed: int = 0) -> Path:
    """Writes an archive of synthetic pavement runs (:func:`roadtex.pavements.synthetic_pavement`)
    as profile files plus ``manifest.csv``, as a survey would deliver it.

    Args:
        folder: where to write (created).
        kinds: pavement kinds, taken in turn.
        runs_per_kind: runs of each kind (each from its own seed).
        run_length: metres per run.
        dx: sampling interval (m).
        file_format: "parquet", "csv" or "npy".
        speed_kmh: the speed written into the manifest (km/h), for band frequencies.
        seed: seed of the first run; run i uses seed + i.

    Returns:
        The manifest's path. An archive already written there with the same arguments is kept as
        it is (so a re-run finds its inputs unchanged); with other arguments it is rewritten.
    """
    from roadtex import __version__
    from roadtex.pavements import synthetic_pavement
    from roadtex.profile import write_profile

    root = Path(folder)
    root.mkdir(parents=True, exist_ok=True)
    suffix = {"parquet": ".parquet", "csv": ".csv", "npy": ".npy"}[file_format]
    recipe = {"kinds": list(kinds), "run_length": run_length, "dx": dx, "seed": seed, "format": file_format,
              "roadtex": __version__}
    stamp = root / "archive.json"
    try:
        same = json.loads(stamp.read_text()) == recipe
    except (OSError, ValueError):
        same = False
    rows = []
    for i in range(runs_per_kind * len(kinds)):
        kind = kinds[i % len(kinds)]
        run_id = f"{kind}_{i // len(kinds) + 1:03d}"
        path = root / f"{run_id}{suffix}"
        if not (same and path.exists()):
            write_profile(synthetic_pavement(kind, run_length, dx, seed=seed + i), path)
        rows.append({"path": path.name, "run_id": run_id, "site": f"synthetic-{run_id}", "pavement": kind,
                     "device": "roadtex synthetic pavement generator", "speed_kmh": speed_kmh})
    manifest = root / "manifest.csv"
    pl.DataFrame(rows).write_csv(manifest)
    stamp.write_text(json.dumps(recipe))
    return manifest


def _unique_run_id(path: Path, root: Path, rows: list[dict[str, Any]]) -> str:
    taken = {r["run_id"] for r in rows}
    if path.stem not in taken:
        return path.stem
    return "_".join(path.relative_to(root).with_suffix("").parts)


# --------------------------------------------------------------------------------------------
# One run
# --------------------------------------------------------------------------------------------

def file_sha256(path: str | os.PathLike[str]) -> str:
    """SHA-256 of a file's bytes (detects changed inputs whatever their timestamps)."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


class _RunFailure(Exception):
    def __init__(self, stage: str, cause: BaseException):
        super().__init__(f"{stage}: {cause}")
        self.stage, self.cause = stage, cause


def _stage(stage: str, action: Callable[[], Any]) -> Any:
    try:
        return action()
    except (ArchiveWriteError, KeyboardInterrupt, MemoryError):
        raise
    except (Exception, pl.exceptions.PanicException) as exc:
        # A panic inside a library (polars, the Rust core) on one bad run is that run's failure.
        raise _RunFailure(stage, exc) from exc


def compute_run(run: dict[str, Any], options: ProcessingOptions, *, threads: int | None = None) -> dict[str, pl.DataFrame]:
    """Reads, conditions, segments, solves and analyses one run; returns its tables (nothing written).

    Raises:
        _RunFailure: with the stage that failed (read, condition, mpd, segment, spectra, solve). A run
            too short for one 100 mm MPD baseline or one segment fails as a whole.
    """
    from roadtex.contact import contact_many
    from roadtex.mpd import mpd as mean_profile_depth
    from roadtex.profile import read_profile
    from roadtex.spectra import REFERENCE_PRESSURE, band_levels, time_frequency

    raw = _stage("read", lambda: read_profile(run["path"], format=run.get("format")))
    conditioned = _stage("condition", lambda: raw.conditioned(dx=options.dx, spike_alpha=options.spike_alpha))
    depth = _stage("mpd", lambda: mean_profile_depth(raw, spike_alpha=options.mpd_spike_alpha))
    segments = _stage("segment", lambda: conditioned.segments(options.segment_length, options.segment_overlap))
    n_segments, n_points = segments.heights.shape
    moduli = np.asarray(options.youngs_moduli)
    n_moduli = moduli.size
    dx = segments.dx
    speed = run.get("speed_kmh")
    speed = options.speed_kmh if speed is None or not np.isfinite(speed) else speed

    baselines = depth.segments
    segment_mpd = _segment_mpd(baselines, segments.starts, segments.length, max(dx, 5e-4))

    segment_rows: dict[str, list[Any]] = {name: [] for name in SEGMENT_SCHEMA}
    band_frames: list[pl.DataFrame] = []
    profile_envelopes = np.empty((n_moduli, n_segments, n_points)) if options.keep_profiles else None
    profile_pressures = np.empty((n_moduli, n_segments, n_points)) if options.keep_profiles else None
    # The contact model sees each segment as one period, so the original segments are analysed
    # the same way as its (periodic) output: exact DFT band powers, no window. Differences
    # enveloped - original then come from the envelopment alone, not from a change of method.
    texture = _stage("spectra", lambda: band_levels(segments.heights, dx, kind=options.band_kind, periodic=True))
    reported = texture.bands["reported"].to_numpy()
    if not reported.any():
        raise _RunFailure("spectra", ValueError(
            f"no {options.band_kind.replace('_', '-')} band is allowed by the sampling ({dx:.3g} m) and the "
            f"segment length ({segments.length:.3g} m); use longer segments"))
    bands = texture.bands.filter(pl.col("reported"))
    band_count = bands.height
    frequency = (_stage("spectra", lambda: time_frequency(bands["centre_wavelength"].to_numpy(), speed))
                 if speed is not None else np.full(band_count, np.nan))

    for first in range(0, n_segments, _CHUNK_SEGMENTS):
        chunk = slice(first, min(first + _CHUNK_SEGMENTS, n_segments))
        heights = segments.heights[chunk]
        batch = _stage("solve", lambda: contact_many(
            heights, dx, moduli, options.mean_pressure, poisson=options.poisson, tol=options.tol,
            max_iterations=options.max_iterations, threads=threads, warm_start=True,
            raise_on_nonconvergence=False))
        count = heights.shape[0]
        envelopes = batch.envelope.reshape(count * n_moduli, n_points)
        pressures = batch.pressure.reshape(count * n_moduli, n_points)
        enveloped = _stage("spectra", lambda: band_levels(envelopes, dx, kind=options.band_kind, periodic=True))
        pressure = _stage("spectra", lambda: band_levels(
            pressures, dx, kind=options.band_kind, periodic=True, reference=REFERENCE_PRESSURE))
        if options.keep_profiles:
            profile_envelopes[:, chunk] = np.moveaxis(batch.envelope, 1, 0)
            profile_pressures[:, chunk] = np.moveaxis(batch.pressure, 1, 0)

        top = heights.max(axis=1)[:, None, None]
        penetration = top - batch.envelope
        gap = batch.envelope - heights[:, None, :]
        index = np.arange(first, first + count)
        seg_index = np.repeat(index, n_moduli)
        mod_index = np.tile(np.arange(n_moduli), count)
        columns = {
            "run_id": [run["run_id"]] * seg_index.size,
            "segment": seg_index,
            "youngs_modulus": moduli[mod_index],
            "start": segments.starts[seg_index],
            "end": segments.starts[seg_index] + segments.length,
            **{name: [run.get(name)] * seg_index.size for name in METADATA_COLUMNS},
            "mpd": segment_mpd[seg_index],
            "rms_height": heights.std(axis=1)[seg_index - first],
            "contact_fraction": (batch.pressure > 0).mean(axis=2).ravel(),
            "mean_penetration": penetration.mean(axis=2).ravel(),
            "max_penetration": penetration.max(axis=2).ravel(),
            "mean_gap": gap.mean(axis=2).ravel(),
            "max_pressure": batch.pressure.max(axis=2).ravel(),
            "residual": batch.residual.ravel(),
            "iterations": batch.iterations.ravel(),
            "converged": batch.converged.ravel(),
        }
        for name, values in columns.items():
            segment_rows[name].extend(np.asarray(values).tolist() if not isinstance(values, list) else values)

        rows = seg_index.size
        band_frames.append(pl.DataFrame({
            "segment": np.repeat(seg_index, band_count),
            "youngs_modulus": np.repeat(moduli[mod_index], band_count),
            "band": np.tile(bands["band"].to_numpy(), rows),
            "label": np.tile(bands["label"].to_numpy(), rows),
            "centre_wavelength": np.tile(bands["centre_wavelength"].to_numpy(), rows),
            "frequency": np.tile(frequency, rows),
            "texture_level": texture.levels[seg_index][:, reported].ravel(),
            "enveloped_level": enveloped.levels[:, reported].ravel(),
            "pressure_level": pressure.levels[:, reported].ravel(),
        }).with_columns(pl.lit(run["run_id"], dtype=pl.String).alias("run_id")).select(
            [pl.col(name).cast(dtype) for name, dtype in BAND_SCHEMA.items()]))

    tables = {
        "segments": pl.DataFrame(segment_rows, schema=SEGMENT_SCHEMA),
        "bands": pl.concat(band_frames).with_columns(pl.col("frequency").fill_nan(None)),
        "run": pl.DataFrame({
            "run_id": [run["run_id"]], "path": [run["path"]], "format": [run.get("format")],
            "points": [conditioned.heights.size],
            "length": [conditioned.length], "dx": [dx], "segments": [n_segments], "mpd": [depth.mpd],
            "dropout_fraction": [raw.dropout_fraction],
        }, schema=RUN_SCHEMA),
    }
    if options.keep_profiles:
        tables["profiles"] = _stitched_profiles(run["run_id"], segments, moduli, profile_envelopes, profile_pressures)
    return tables


def _segment_mpd(baselines: pl.DataFrame, starts: np.ndarray, length: float, dx: float) -> np.ndarray:
    """Mean of the valid ISO baselines lying inside each segment, to within one sample (NaN where none)."""
    valid = baselines.filter(pl.col("valid")).sort("start")
    b_start = valid["start"].to_numpy()
    b_end = valid["end"].to_numpy()
    cumulative = np.concatenate([[0.0], np.cumsum(valid["msd"].to_numpy())])
    # Segments start at a sample, baselines at a sample interval's edge (half a sample earlier),
    # and the two grids may differ (MPD resamples to 0.5 mm): allow one sample either way.
    slack = dx
    # Baselines have equal lengths, so sorting by start sorts the ends too.
    first = np.searchsorted(b_start, starts - slack, side="left")
    last = np.searchsorted(b_end, starts + length + slack, side="right")
    count = np.maximum(last - first, 0)
    out = np.full(starts.size, np.nan)
    has = count > 0
    out[has] = (cumulative[last[has]] - cumulative[first[has]]) / count[has]
    return out


def _stitched_profiles(run_id: str, segments: Any, moduli: np.ndarray, envelopes: np.ndarray,
                       pressures: np.ndarray) -> pl.DataFrame:
    frames = []
    heights_positions, heights = segments.stitch(segments.heights, add_trend=True)
    for k, modulus in enumerate(moduli):
        _, envelope = segments.stitch(envelopes[k], add_trend=True)
        _, pressure = segments.stitch(pressures[k])
        frames.append(pl.DataFrame({
            "run_id": [run_id] * heights.size, "youngs_modulus": np.full(heights.size, modulus),
            "position": heights_positions, "height": heights, "envelope": envelope, "pressure": pressure,
        }, schema=PROFILE_SCHEMA))
    return pl.concat(frames)


# --------------------------------------------------------------------------------------------
# Atomic writing and run status
# --------------------------------------------------------------------------------------------

def _write_atomically(path: Path, write: Callable[[Path], None]) -> None:
    temporary = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    try:
        write(temporary)
        with open(temporary, "rb+") as stream:
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except Exception as exc:
        # polars reports a full disk as its own ComputeError ("... os error 28"), not OSError:
        # any failure to write output is a write failure, and stops the job.
        temporary.unlink(missing_ok=True)
        code = exc.errno if isinstance(exc, OSError) else None
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise ArchiveWriteError(code, f"cannot write {path}: {reason}") from exc


def _write_json(path: Path, payload: dict[str, Any]) -> None:
    _write_atomically(path, lambda p: p.write_text(json.dumps(payload, indent=1, sort_keys=True, default=str)))


def _read_status(run_dir: Path) -> dict[str, Any] | None:
    try:
        return json.loads((run_dir / _STATUS).read_text())
    except (OSError, ValueError):
        return None


def _run_fingerprint(options_fingerprint: str, input_sha256: str, run: dict[str, Any]) -> str:
    metadata = {name: run.get(name) for name in (*METADATA_COLUMNS, "format")}
    payload = json.dumps([options_fingerprint, input_sha256, metadata], sort_keys=True, default=str)
    return hashlib.sha256(payload.encode()).hexdigest()


def process_run(run: dict[str, Any], options: ProcessingOptions, out_dir: str | os.PathLike[str], *,
                threads: int | None = None, force: bool = False) -> dict[str, Any]:
    """Processes one manifest row and writes its outputs atomically to ``out_dir/runs/<run_id>/``.

    Skips the work when the run's status already matches the options and the input file.

    Returns:
        The run's status: ``state`` ("ok", "error" or "skipped"), fingerprints, ``kilometres`` and,
        on error, ``stage``, ``error_type`` and ``message``.

    Raises:
        ArchiveWriteError: the outputs could not be written.
    """
    run_dir = Path(out_dir) / "runs" / run["run_id"]
    options_fingerprint = options.fingerprint()
    try:
        input_sha256 = file_sha256(run["path"])
    except OSError as exc:
        input_sha256 = f"unreadable: {exc}"
    fingerprint = _run_fingerprint(options_fingerprint, input_sha256, run)
    previous = _read_status(run_dir)
    if not force and previous is not None and previous.get("fingerprint") == fingerprint:
        return {**previous, "skipped": True}
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
        (run_dir / _STATUS).unlink(missing_ok=True)  # from here until the new status lands, the run is not done
    except OSError as exc:
        raise ArchiveWriteError(exc.errno, f"cannot write to {run_dir}: {exc.strerror or exc}") from exc
    started = time.perf_counter()
    status: dict[str, Any] = {"run_id": run["run_id"], "path": run["path"], "fingerprint": fingerprint,
                              "options_fingerprint": options_fingerprint, "input_sha256": input_sha256}
    try:
        tables = compute_run(run, options, threads=threads)
    except _RunFailure as failure:
        status.update(state="error", stage=failure.stage, error_type=type(failure.cause).__name__,
                      message=str(failure.cause), kilometres=0.0)
    else:
        for name, table in tables.items():
            _write_atomically(run_dir / f"{name}.parquet", lambda p, t=table: t.write_parquet(p, statistics=True))
        status.update(state="ok", kilometres=float(tables["run"]["length"][0]) / 1e3,
                      seconds=time.perf_counter() - started)
    for stale in ("segments", "bands", "run", "profiles"):
        if status["state"] != "ok" or (stale == "profiles" and not options.keep_profiles):
            (run_dir / f"{stale}.parquet").unlink(missing_ok=True)
    _write_json(run_dir / _STATUS, status)
    return {**status, "skipped": False}


# --------------------------------------------------------------------------------------------
# The job
# --------------------------------------------------------------------------------------------

def process(manifest: str | os.PathLike[str] | pl.DataFrame, out_dir: str | os.PathLike[str],
            options: ProcessingOptions | None = None, *, engine: Engine = "local", scheduler: str | None = None,
            workers: int = 2, threads: int | None = None, quiet: bool = False, force: bool = False,
            extra_columns: Sequence[str] = ()) -> ProcessSummary:
    """Processes every run of a manifest and writes the combined tables to ``out_dir``.

    Args:
        manifest: manifest file (CSV/Parquet) or DataFrame, see :func:`read_manifest`.
        out_dir: output folder (created).
        options: what to compute; default :class:`ProcessingOptions()`.
        engine: "local" (two runs at a time on this machine, segments in parallel on ``threads``
            Rust threads) or "dask" (runs distributed over Dask workers).
        scheduler: Dask scheduler address; None starts a local cluster of ``workers`` processes.
        workers: worker processes of the local Dask cluster.
        threads: Rust threads per solve batch (None: all cores; with the local Dask cluster the
            default is one per worker).
        quiet: no progress bar; one log line per run instead (logger ``roadtex.archive``).
        force: recompute runs even when their status is current.

    Returns:
        A :class:`ProcessSummary`.

    Raises:
        ManifestError: a bad manifest (before any work starts).
        ArchiveWriteError: the output folder cannot be written.
    """
    options = options or ProcessingOptions()
    table = read_manifest(manifest, extra_columns=extra_columns)
    out = Path(out_dir)
    _check_writable(out)
    _remove_stale_temporaries(out)
    runs = table.to_dicts()
    sizes = [_size(run["path"]) for run in runs]
    started = time.perf_counter()
    progress = _Progress(len(runs), sum(sizes), quiet)
    statuses: dict[str, dict[str, Any]] = {}
    try:
        if engine == "local":
            for status, size in _process_local(runs, sizes, options, out, threads, force):
                statuses[status["run_id"]] = status
                progress.update(status, size)
        elif engine == "dask":
            for status, size in _process_dask(runs, sizes, options, out, scheduler, workers, threads, force):
                statuses[status["run_id"]] = status
                progress.update(status, size)
        else:
            raise ValueError(f"engine must be 'local' or 'dask', got {engine!r}")
    finally:
        progress.close()
    tables = combine(table, out, options)
    counts = {state: sum(1 for s in statuses.values() if s["state"] == state and not s["skipped"])
              for state in ("ok", "error")}
    return ProcessSummary(
        out_dir=out, runs=len(runs), processed=counts["ok"], failed=counts["error"],
        skipped=sum(1 for s in statuses.values() if s["skipped"]),
        kilometres=sum(float(s.get("kilometres", 0.0)) for s in statuses.values() if not s["skipped"]),
        seconds=time.perf_counter() - started, tables=tables)


def _size(path: str) -> int:
    try:
        return os.path.getsize(path)
    except OSError:
        return 0


def _check_writable(out: Path) -> None:
    try:
        (out / "runs").mkdir(parents=True, exist_ok=True)
        probe = out / f".write-probe-{uuid.uuid4().hex}"
        probe.write_bytes(b"roadtex")
        probe.unlink()
    except OSError as exc:
        raise ArchiveWriteError(exc.errno, f"output folder {out} is not writable: {exc.strerror or exc}") from exc


#: Runs in flight on the local engine. Two, so that one run's reading, conditioning, spectra and
#: writing (Python, one core) overlap the other's contact solve (Rust, every core, GIL released):
#: about 20 % of a run's time is Python. Memory holds at most this many runs.
_LOCAL_RUNS_IN_FLIGHT = 2


def _process_local(runs: list[dict[str, Any]], sizes: list[int], options: ProcessingOptions, out: Path,
                   threads: int | None, force: bool) -> Iterable[tuple[dict[str, Any], int]]:
    """Runs in manifest order, a bounded number at a time; yields (status, size) as each finishes."""
    from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

    pending = list(zip(runs, sizes))[::-1]
    with ThreadPoolExecutor(max_workers=_LOCAL_RUNS_IN_FLIGHT, thread_name_prefix="roadtex-run") as pool:
        in_flight: dict[Any, int] = {}
        try:
            while pending or in_flight:
                while pending and len(in_flight) < _LOCAL_RUNS_IN_FLIGHT:
                    run, size = pending.pop()
                    in_flight[pool.submit(process_run, run, options, out, threads=threads, force=force)] = size
                done, _ = wait(in_flight, return_when=FIRST_COMPLETED)
                for future in done:
                    size = in_flight.pop(future)
                    yield future.result(), size
        finally:
            for future in in_flight:
                future.cancel()


def _remove_stale_temporaries(out: Path) -> None:
    """Deletes the temporary files of a job that was killed while writing (never complete outputs)."""
    for temporary in [*out.glob(".*.tmp"), *(out / "runs").glob("*/.*.tmp")]:
        temporary.unlink(missing_ok=True)


def _process_dask(runs: list[dict[str, Any]], sizes: list[int], options: ProcessingOptions, out: Path,
                  scheduler: str | None, workers: int, threads: int | None, force: bool) -> Iterable[tuple[dict[str, Any], int]]:
    try:
        from distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise RuntimeError("engine='dask' needs dask.distributed: pip install 'roadtex[dask]'") from None
    cluster = None
    if scheduler is None:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        threads = 1 if threads is None else threads
        client = Client(cluster)
    else:
        client = Client(scheduler)
    try:
        by_key = {}
        futures = []
        for run, size in zip(runs, sizes):
            future = client.submit(process_run, run, options, str(out), threads=threads, force=force,
                                   key=f"roadtex-run-{run['run_id']}-{uuid.uuid4().hex[:8]}", pure=False)
            by_key[future.key] = size
            futures.append(future)
        for future in as_completed(futures):
            yield future.result(), by_key[future.key]
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


class _Progress:
    """A progress bar over bytes of input (for the ETA), showing runs and kilometres done."""

    def __init__(self, runs: int, total_bytes: int, quiet: bool):
        self.runs, self.done, self.km, self.quiet = runs, 0, 0.0, quiet
        self.bar = None
        if not quiet:
            from tqdm import tqdm

            self.bar = tqdm(total=max(total_bytes, 1), unit="B", unit_scale=True, desc=f"runs 0/{runs}",
                            file=sys.stderr, dynamic_ncols=True)

    def update(self, status: dict[str, Any], size: int) -> None:
        self.done += 1
        self.km += float(status.get("kilometres", 0.0))
        state = "skipped" if status.get("skipped") else status["state"]
        if self.bar is not None:
            self.bar.set_description(f"runs {self.done}/{self.runs}")
            self.bar.set_postfix_str(f"{self.km:.3f} km", refresh=False)
            self.bar.update(size)
        else:
            detail = f": {status.get('stage')}: {status.get('message')}" if state == "error" else ""
            log.info("run %d/%d %s %s (%.3f km so far)%s", self.done, self.runs, status["run_id"], state, self.km, detail)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def combine(manifest: pl.DataFrame, out_dir: str | os.PathLike[str], options: ProcessingOptions) -> dict[str, Path]:
    """Concatenates the per-run tables of the runs in ``manifest`` (in its order) into the combined tables.

    Only runs whose status is current for ``options`` count; stale folders are ignored. The
    tables are streamed from the per-run files to the combined file (polars' streaming sink), so
    memory does not grow with the archive.
    """
    out = Path(out_dir)
    options_fingerprint = options.fingerprint()
    parts: dict[str, list[Path]] = {"segments": [], "bands": [], "runs": []}
    errors: list[dict[str, Any]] = []
    for run in manifest.iter_rows(named=True):
        run_dir = out / "runs" / run["run_id"]
        status = _read_status(run_dir)
        if status is None or status.get("options_fingerprint") != options_fingerprint:
            continue
        if status["state"] == "error":
            errors.append({name: status.get(name) for name in ERROR_SCHEMA})
            continue
        parts["segments"].append(run_dir / "segments.parquet")
        parts["bands"].append(run_dir / "bands.parquet")
        parts["runs"].append(run_dir / "run.parquet")
    schemas = {"segments": SEGMENT_SCHEMA, "bands": BAND_SCHEMA, "runs": RUN_SCHEMA}
    written = {}
    for name, files in parts.items():
        path = out / f"{name}.parquet"
        if files:
            query = pl.scan_parquet(files, schema=schemas[name])
            _write_atomically(path, lambda p, q=query: q.sink_parquet(p, statistics=True))
        else:
            empty = pl.DataFrame(schema=schemas[name])
            _write_atomically(path, lambda p, t=empty: t.write_parquet(p, statistics=True))
        written[name] = path
    error_table = pl.DataFrame(errors, schema=ERROR_SCHEMA)
    _write_atomically(out / "errors.parquet", lambda p: error_table.write_parquet(p))
    written["errors"] = out / "errors.parquet"
    _write_json(out / "parameters.json", {
        "options": dataclasses.asdict(options), "options_fingerprint": options_fingerprint,
        "versions": software_versions(), "runs": manifest.height,
    })
    written["parameters"] = out / "parameters.json"
    if options.keep_profiles:
        written["profiles"] = out / "runs"
    return written


def software_versions() -> dict[str, str]:
    """Versions of roadtex and what it computes with (recorded in parameters.json)."""
    from roadtex import __version__

    return {"roadtex": __version__, "python": platform.python_version(), "numpy": np.__version__,
            "polars": pl.__version__, "platform": platform.platform()}


def read_profiles(out_dir: str | os.PathLike[str], *, run_id: str | None = None, start: float | None = None,
                  end: float | None = None, youngs_modulus: float | None = None) -> pl.DataFrame:
    """Reads stitched enveloped profiles and pressures back, by run and position range (m).

    Needs a job run with ``keep_profiles=True``; columns as :data:`PROFILE_SCHEMA`.
    """
    root = Path(out_dir) / "runs"
    pattern = str(root / (run_id if run_id is not None else "*") / "profiles.parquet")
    if not any(root.glob(f"{run_id if run_id is not None else '*'}/profiles.parquet")):
        raise FileNotFoundError(f"no profiles under {root}{' for run ' + run_id if run_id else ''}; "
                                "process with keep_profiles=True (--keep-profiles)")
    query = pl.scan_parquet(pattern)
    if start is not None:
        query = query.filter(pl.col("position") >= start)
    if end is not None:
        query = query.filter(pl.col("position") < end)
    if youngs_modulus is not None:
        query = query.filter(pl.col("youngs_modulus") == float(youngs_modulus))
    return query.collect()


def remove_outputs(out_dir: str | os.PathLike[str]) -> None:
    """Deletes a job's outputs (the per-run folders and the combined tables)."""
    out = Path(out_dir)
    shutil.rmtree(out / "runs", ignore_errors=True)
    for name in ("segments", "bands", "runs", "errors"):
        (out / f"{name}.parquet").unlink(missing_ok=True)
    (out / "parameters.json").unlink(missing_ok=True)
