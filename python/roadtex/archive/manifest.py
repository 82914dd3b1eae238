"""The manifest: which runs (profile files) a job processes, with their metadata."""

from __future__ import annotations

import difflib
import errno
import json
import os
import warnings
from pathlib import Path
from typing import Any, Sequence

import polars as pl

from roadtex.archive.manifest_text import blank_rows, canonical_columns, read_text_manifest
from roadtex.archive.options import MAX_SPEED_KMH
from roadtex.archive.schemas import MANIFEST_COLUMNS, METADATA_COLUMNS, NOISE_PREFIX, READER_COLUMNS
from roadtex.archive.store import STATUS_FILE
from roadtex.errors import CoarseSamplingWarning, ImplausibleTextureWarning, ManifestError, RoadtexWarning
from roadtex.profiles.plausibility import (
    coarse_sampling,
    implausible_across,
    implausible_surface,
    implausible_texture,
    judged_once,
    stated_distance_unit,
)
from roadtex.profiles.readers import file_head, guess_format, limits, read_profile
from roadtex.profiles.readers.text import excerpt
from roadtex.surfaces.readers import is_surface_file, read_surface

#: File suffixes :func:`build_manifest` lists as profile files.
PROFILE_SUFFIXES = {".dat", ".csv", ".tsv", ".txt", ".npy", ".parquet", ".crg", ".x3p"}
#: The longest run id (UTF-8 bytes): it names the run's output folder (file systems: 255 bytes a name).
MAX_RUN_ID_BYTES = 200
#: Names Windows reserves for devices, with or without a suffix (``con``, ``con.txt``; any case): no
#: folder can have them there, so no run id may (an archive moves between machines).
RESERVED_NAMES = {"con", "prn", "aux", "nul", *(f"{d}{i}" for d in ("com", "lpt") for i in range(1, 10))}
#: Characters no file or folder name on Windows may hold (besides / and \\, refused everywhere).
WINDOWS_FORBIDDEN = frozenset('<>:"|?*')
#: Suffixes of compressed files, which no reader opens: :func:`unlisted_files` says so.
COMPRESSED_SUFFIXES = {".gz", ".zip", ".bz2", ".xz", ".7z", ".zst", ".rar", ".tgz"}


def json_has(path: Path, key: str) -> bool:
    """Whether ``path`` is a JSON object holding ``key`` (False for anything else)."""
    try:
        return path.is_file() and key in json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, TypeError):
        return False


def is_job_output(folder: Path) -> bool:
    """Whether ``folder`` holds a roadtex job's outputs (its ``parameters.json``, a run's
    ``status.json``, or run folders with status files: a job interrupted before its tables), which
    are no survey data: listing them would make a job of its own Parquet tables."""
    if json_has(folder / "parameters.json", "options_fingerprint") or json_has(folder / STATUS_FILE, "fingerprint"):
        return True
    runs = folder / "runs"
    return runs.is_dir() and any(json_has(status, "fingerprint") for status in runs.glob(f"*/{STATUS_FILE}"))


def job_output_folders(root: Path, recursive: bool = True) -> list[Path]:
    """The folders under ``root`` (``root`` itself included) that hold a job's outputs
    (:func:`is_job_output`), outermost only: :func:`build_manifest` skips them."""
    if is_job_output(root):
        return [root]
    found = []
    for folder, subfolders, _ in os.walk(root) if recursive else ():
        keep = []
        for name in sorted(subfolders):
            if is_job_output(Path(folder) / name):
                found.append(Path(folder) / name)
            else:
                keep.append(name)
        subfolders[:] = keep   # not descended into
    return found


def candidate_files(root: Path, recursive: bool) -> list[Path]:
    """The files of a survey folder :func:`build_manifest` considers: not hidden, not a manifest,
    not in a folder holding a job's outputs (:func:`job_output_folders`)."""
    skipped = job_output_folders(root, recursive)
    return sorted(p for p in (root.rglob("*") if recursive else root.glob("*"))
                  if p.is_file() and not p.name.lower().startswith("manifest") and not p.name.startswith(".")
                  and not any(p.is_relative_to(folder) for folder in skipped))


def unlisted_files(folder: str | os.PathLike[str], *, recursive: bool = True) -> list[str]:
    """The files of ``folder`` that :func:`build_manifest` does not list (a suffix other than
    :data:`PROFILE_SUFFIXES`; hidden files and ``manifest*`` files aside; symbolic links that loop
    or point to nothing), each as "name: why", so that no profile is left out without a word (a
    gzipped export, a spreadsheet)."""
    root = Path(folder)
    listed = ", ".join(sorted(PROFILE_SUFFIXES))
    notes = []
    for path in sorted(root.rglob("*") if recursive else root.glob("*")):
        if path.is_symlink() and not path.exists():   # is_file() is False for it: it would go unsaid
            try:
                path.resolve(strict=True)
                why = "cannot be followed"
            except RuntimeError:
                why = "loops (it leads back to itself)"
            except OSError as exc:
                why = "loops (it leads back to itself)" if exc.errno == errno.ELOOP else "points to nothing"
            notes.append(f"{path.relative_to(root).as_posix()}: a symbolic link that {why}")
    for path in candidate_files(root, recursive):
        if path.suffix.lower() in PROFILE_SUFFIXES:
            continue
        if path.suffix.lower() == ".json" and Path(path.as_posix()[:-5]).suffix.lower() in PROFILE_SUFFIXES \
                and Path(path.as_posix()[:-5]).is_file():
            continue   # a sidecar (x.npy.json: dx, dy and units of x.npy), read with its file
        name = path.relative_to(root).as_posix()
        if path.suffix.lower() in COMPRESSED_SUFFIXES:
            notes.append(f"{name}: compressed ({path.suffix}); roadtex reads no compressed files: decompress it "
                         "(e.g. gunzip) into the folder and run roadtex manifest again")
        else:
            suffix = f"suffix {path.suffix!r}" if path.suffix else "no suffix"
            notes.append(f"{name}: {suffix}, not one of the profile files' ({listed})")
    return notes


def read_manifest(source: str | os.PathLike[str] | pl.DataFrame, *, base_dir: str | os.PathLike[str] | None = None,
                  extra_columns: Sequence[str] = ()) -> pl.DataFrame:
    """Reads and checks a manifest (CSV or Parquet, or a DataFrame), before any work starts.

    Columns: ``path`` (required; relative paths are taken from the manifest's folder or
    ``base_dir``), optional ``run_id`` (default: the file name without suffix; must be unique),
    ``format`` (as for :func:`roadtex.read_profile`; default: guessed; ``surface`` makes the run a
    3D surface run read by :func:`roadtex.read_surface`, as does a ``.crg`` file; left empty, a file
    that :func:`~roadtex.surfaces.readers.is_surface_file` finds a surface gets ``surface``, as
    :func:`build_manifest` gives it), the metadata columns
    :data:`METADATA_COLUMNS` (``speed_kmh`` in km/h), reader options per run
    (:data:`READER_COLUMNS`: ``distance_unit``, ``height_unit``, ``delimiter``, ``decimal``, ``dx``
    in m for heights-only files, ...; see :func:`roadtex.read_profile`; ``dy`` in m across the road
    for surfaces) and measured noise levels
    ``noise_<band>`` (dB). Any other column must be named in ``extra_columns`` (it is then carried along unused).

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
        where, text, notes = "manifest (a DataFrame)", False, []
    else:
        manifest_path = Path(source)
        base = Path(base_dir) if base_dir is not None else manifest_path.resolve().parent
        where = f"manifest {manifest_path}"
        if not manifest_path.is_file():
            raise ManifestError(f"{where} does not exist or is not a file")
        text = manifest_path.suffix.lower() != ".parquet"
        notes: list[str] = []
        try:
            if not text:
                rows, columns = limits.parquet_size(manifest_path, str(manifest_path))
                if rows * columns > limits.MAX_POINTS:   # before polars allocates it: it aborts when it cannot
                    raise ManifestError(f"{where} declares {rows:,} rows x {columns} columns, beyond the "
                                        f"{limits.MAX_POINTS:,} cells a manifest may hold (refused unread)")
                table = pl.read_parquet(manifest_path)
            else:
                table = read_text_manifest(manifest_path, notes)
        except ManifestError:
            raise
        except Exception as exc:  # polars raises several exception types for malformed files
            raise ManifestError(f"cannot read {where}: {exc}") from None

    table = canonical_columns(table, where, extra_columns)   # "Path", "Run ID": path, run_id
    # wholly empty rows (a blank line at the end, a spreadsheet's cleared rows ";;") are no runs;
    # the others keep their row numbers in the messages
    empty = blank_rows(table)
    rows_at = [index for index, blank in enumerate(empty.to_list()) if not blank]
    if len(rows_at) < table.height:
        notes.append(f"{table.height - len(rows_at)} wholly empty row(s) left out (data row(s) "
                     f"{', '.join(str(i + 1) for i in range(table.height) if empty[i])[:80]})")
        table = table.filter(~empty)

    def cell(index: int, column: str) -> str:
        """Where a cell is: the manifest, its 1-based data row (and line, in a text file) and column."""
        row = rows_at[index]
        line = f", line {row + 2} of the file" if text else ""
        return f"{where}, data row {row + 1} (1-based, header not counted{line}), column {column!r}"

    for note in notes:   # said once, as the manifest is read (roadtex process shows it)
        warnings.warn(f"{where}: {note}", RoadtexWarning, stacklevel=2)
    if "path" not in table.columns:
        raise ManifestError(f"{where} has no 'path' column (columns: {', '.join(table.columns) or 'none'})")
    known = {**MANIFEST_COLUMNS, **READER_COLUMNS}
    unknown = [c for c in table.columns
               if c not in known and not c.startswith(NOISE_PREFIX) and c not in extra_columns]
    if unknown:
        shown = ", ".join(excerpt(name) for name in unknown[:8]) + (f" and {len(unknown) - 8} more" if len(unknown) > 8 else "")
        raise ManifestError(
            f"{where} has unknown column(s) {shown}{column_hints(unknown[:8], known)}; known: "
            f"{', '.join(MANIFEST_COLUMNS)}; reader options {', '.join(READER_COLUMNS)}; "
            f"and {NOISE_PREFIX}<band> for noise levels (dB); "
            "in Python, pass extra_columns to carry others along")
    if table.height == 0:
        raise ManifestError(f"{where} lists no runs")
    casts = []
    for name, dtype in MANIFEST_COLUMNS.items():
        if name not in table.columns:
            casts.append(pl.lit(None, dtype=dtype).alias(name))
        else:
            casts.append(pl.col(name).cast(dtype, strict=False).alias(name))
    for name, dtype in READER_COLUMNS.items():
        if name in table.columns:
            casts.append(pl.col(name).cast(dtype, strict=False).alias(name))
    for name in table.columns:
        if name.startswith(NOISE_PREFIX):
            casts.append(pl.col(name).cast(pl.Float64, strict=False).alias(name))
    indexed = table.with_row_index("__row__")
    numeric = [n for n, t in READER_COLUMNS.items() if t is pl.Float64]
    for name in ("speed_kmh", *numeric, *[c for c in table.columns if c.startswith(NOISE_PREFIX)]):
        if name in table.columns:
            bad = indexed.filter(pl.col(name).is_not_null()
                                 & pl.col(name).cast(pl.Float64, strict=False).is_null())
            if bad.height:
                raise ManifestError(f"{cell(bad['__row__'][0], name)}: must be numeric, found {bad[name][0]!r}")
    for name, unit in (("speed_kmh", "km/h"), ("dx", "m"), ("dy", "m")):
        if name in table.columns:
            value = pl.col(name).cast(pl.Float64, strict=False)
            bad = indexed.filter(value.is_not_null() & ~(value > 0))
            if bad.height:
                raise ManifestError(f"{cell(bad['__row__'][0], name)}: must be positive ({unit}), found {bad[name][0]!r}")
    if "speed_kmh" in table.columns:   # as ProcessingOptions.speed_kmh: no road vehicle goes faster
        fast = indexed.filter(pl.col("speed_kmh").cast(pl.Float64, strict=False) > MAX_SPEED_KMH)
        if fast.height:
            raise ManifestError(f"{cell(fast['__row__'][0], 'speed_kmh')}: {fast['speed_kmh'][0]!r} km/h is faster "
                                f"than any road vehicle (at most {MAX_SPEED_KMH:g} km/h)")
    if "decimal" in table.columns:
        bad_marks = indexed.filter(pl.col("decimal").is_not_null() & ~pl.col("decimal").is_in([".", ","]))
        if bad_marks.height:
            raise ManifestError(f"{cell(bad_marks['__row__'][0], 'decimal')}: must be '.' or ',', "
                                f"found {bad_marks['decimal'][0]!r}")
    table = table.with_columns(casts)
    # blanks around a path or run id (a spreadsheet's "a.csv ") are no part of it
    table = table.with_columns(pl.col(name).str.strip_chars().replace("", None) for name in ("path", "run_id"))
    if table["path"].null_count():
        first = int(table["path"].is_null().arg_max() or 0)
        raise ManifestError(f"{cell(first, 'path')}: empty; every run needs a file "
                            f"({table['path'].null_count()} empty path(s) in all)")
    paths = [str((base / p).resolve()) if not Path(p).is_absolute() else str(Path(p)) for p in table["path"]]
    missing = [i for i, p in enumerate(paths) if not Path(p).exists()]
    if missing:
        given = Path(table["path"][missing[0]])
        hint = ""
        if not given.is_absolute():
            hint = f"; relative paths are taken from the manifest's folder, {base}"
            if (Path.cwd() / given).exists() and Path.cwd().resolve() != base.resolve():
                hint += (f" ({given} is a file from the current folder, {Path.cwd()}: write the paths relative "
                         "to the manifest's folder, or absolute)")
        raise ManifestError(f"{cell(missing[0], 'path')}: no file {paths[missing[0]]} "
                            f"({len(missing)} file(s) listed in the manifest do not exist){hint}")
    # A folder, a device (/dev/zero) or a pipe listed as a run is that run's failure, not the
    # manifest's: one bad row never stops a job. Nothing reads or hashes such a path (file_head,
    # file_sha256 refuse it: /dev/zero never ends).
    run_ids = [rid if rid else Path(p).stem for rid, p in zip(table["run_id"].to_list(), paths)]
    seen: dict[str, int] = {}
    folded: dict[str, int] = {}   # run ids ignoring case: one folder where case is not told apart
    for index, rid in enumerate(run_ids):
        if rid in seen:
            raise ManifestError(f"{cell(index, 'run_id')}: run id {rid!r} appears twice (also data row {rows_at[seen[rid]] + 1}; "
                                "a run id left empty is the file name without suffix); give each run a unique run_id")
        if not rid or "/" in rid or "\\" in rid or rid in (".", ".."):
            raise ManifestError(f"{cell(index, 'run_id')}: run id {rid!r} cannot name an output folder")
        if any(ord(c) < 32 or ord(c) == 127 for c in rid):
            raise ManifestError(f"{cell(index, 'run_id')}: run id {rid[:60]!r} contains a control character (a NUL "
                                "byte, a tab or a line break): it cannot name an output folder")
        problem = folder_name_problem(rid)
        if problem is not None:
            raise ManifestError(f"{cell(index, 'run_id')}: run id {rid[:60]!r} {problem}; give the run another run_id")
        if rid.casefold() in folded:
            other = folded[rid.casefold()]
            raise ManifestError(f"{cell(index, 'run_id')}: run id {rid!r} and {run_ids[other]!r} (data row "
                                f"{rows_at[other] + 1}) differ only in case: they name one folder on Windows and macOS "
                                "(an archive moves between machines); give each run a unique run_id")
        if len(rid.encode("utf-8")) > MAX_RUN_ID_BYTES:
            raise ManifestError(f"{cell(index, 'run_id')}: run id {rid[:40]!r}... is {len(rid.encode('utf-8'))} bytes "
                                f"long; at most {MAX_RUN_ID_BYTES} (it names the run's output folder, and file systems "
                                "allow 255 bytes a name)")
        seen[rid] = index
        folded[rid.casefold()] = index
    # a surface file listed without a format (a hand-written manifest: a 2-D .npy with dx and dy) is
    # a surface run, as roadtex manifest would have marked it
    formats = [fmt if fmt is not None or not is_surface_file(path) else "surface"
               for fmt, path in zip(table["format"].to_list(), paths)]
    return table.with_columns(pl.Series("path", paths), pl.Series("run_id", run_ids),
                              pl.Series("format", formats, dtype=pl.String))


#: Manifest columns users write for what is a job option, not a per-run column.
JOB_OPTION_COLUMNS = {"youngs_modulus": "--moduli", "youngs_moduli": "--moduli", "modulus": "--moduli",
                      "moduli": "--moduli", "e": "--moduli", "mean_pressure": "--pressure", "pressure": "--pressure",
                      "segment_length": "--segment-length", "tol": "--tol", "poisson": "--poisson"}


def column_hints(unknown: Sequence[str], known: Sequence[str]) -> str:
    """What each unknown manifest column was probably meant to be: a misspelled known column, or a
    job option (E, P, ...) that the command line takes for the whole job."""
    hints = []
    for column in unknown:
        option = JOB_OPTION_COLUMNS.get(column.strip().lower())
        close = difflib.get_close_matches(column.strip().lower(), list(known), n=1, cutoff=0.75)
        if option is not None:
            hints.append(f"{column!r} is a job option, not a manifest column: roadtex process {option} "
                         "(ProcessingOptions in Python) sets it for every run")
        elif close:
            hints.append(f"{column!r}: did you mean {close[0]!r}?")
    return f" ({'; '.join(hints)})" if hints else ""


def build_manifest(folder: str | os.PathLike[str], *, recursive: bool = True, read_metadata: bool = True) -> pl.DataFrame:
    """Lists the profile files of a folder as a manifest (one run per file, sorted by path).

    Files with suffix .dat (CAPTIF), .csv, .tsv, .txt, .npy, .parquet, .crg or .x3p are listed, except
    hidden files, files named ``manifest*`` (a manifest kept beside its data) and folders holding a
    job's outputs (:func:`job_output_folders`: ``roadtex process --out`` inside the survey folder). 3-D surfaces
    (:func:`roadtex.surfaces.readers.is_surface_file`: OpenCRG, ISO 25178-72 X3P, a 2-D ``.npy``, a table with x,
    y and z columns) get ``format`` "surface" and are processed as surface runs. With
    ``read_metadata`` each file is read and the metadata it carries (site, wheel path, date,
    device, direction) fills the manifest columns, and a profile's ``format`` is the one it was
    read as; a profile that cannot be read is still listed (``format`` null), as is a surface
    (``format`` "surface"), so the job records why it fails.

    Returns:
        A manifest DataFrame with absolute paths; save it with ``write_csv`` and edit it freely.
    """
    root = Path(folder)
    if not root.is_dir():
        raise ManifestError(f"{root} is not a folder")
    if is_job_output(root):
        raise ManifestError(f"{root} holds a roadtex job's outputs (parameters.json, runs/*/status.json), not survey "
                            "data: give the folder of the profile files")
    files = [p for p in candidate_files(root, recursive) if p.suffix.lower() in PROFILE_SUFFIXES]
    if not files:
        others = unlisted_files(root, recursive=recursive)
        found = f"; not listed: {'; '.join(others[:5])}{' ...' if len(others) > 5 else ''}" if others else ""
        raise ManifestError(f"no profile files (.dat, .csv, .tsv, .txt, .npy, .parquet, .crg, .x3p) in {root}{found}")
    rows = []
    for path in files:
        row: dict[str, Any] = {"path": str(path.resolve()), "run_id": unique_run_id(path, root, rows)}
        # a 3-D surface (OpenCRG, 2-D .npy, a table of x, y, z columns) is a surface run, whether
        # or not it reads as it is (a .npy without dx): the job then records why it fails
        surface = is_surface_file(path)   # OpenCRG and X3P by their suffix, the others by their content
        if surface:
            row["format"] = "surface"
        if read_metadata:
            implausible = coarse = None
            try:
                if surface:
                    with judged_once():   # judged below as the job judges it, and warned about once
                        read = read_surface(path)
                    metadata = read.metadata
                    stated = stated_distance_unit(metadata)
                    implausible = (implausible_surface(read.heights, read.dx, path.name, interval_stated=stated is not None)
                                   or implausible_across(read.dy, read.shape[0], path.name))
                    coarse = coarse_sampling(read.dx, path.name, stated) if stated is not None else None
                else:
                    with judged_once():   # judged below, and warned about once
                        profile = read_profile(path)
                    metadata = profile.metadata
                    # the format the file was read as, so that runs.parquet says it (its metadata's
                    # "format" may be an earlier one's: a CAPTIF profile written to Parquet keeps it)
                    row["format"] = guess_format(path, file_head(path))
                    stated = stated_distance_unit(profile.metadata)
                    implausible = implausible_texture(profile.heights, profile.dx, path.name,
                                                      interval_stated=stated is not None)
                    coarse = coarse_sampling(profile.dx, path.name, stated) if stated is not None else None
            except Exception:  # listed anyway: the job records why it fails
                metadata = {}
            if implausible is not None:
                # what the job will do with it (refuse it), not the reader's "computing as given"
                warnings.warn(f"{implausible} roadtex process refuses it unless its manifest row gives the units "
                              "its header lacks (distance_unit, height_unit; a wrong unit in the header must be "
                              "corrected in the file) or, for heights only, dx in metres; --allow-implausible "
                              "processes it as read", ImplausibleTextureWarning, stacklevel=2)
            elif coarse is not None:   # what process will warn of (the readers' own warning is silenced above)
                warnings.warn(coarse, CoarseSamplingWarning, stacklevel=2)
            for name in METADATA_COLUMNS:
                if name in metadata and metadata[name] is not None:
                    row[name] = metadata_cell(name, metadata[name], path.name)
        rows.append(row)
    unportable = [f"{path.relative_to(root).as_posix()} -> {row['run_id']}" for path, row in zip(files, rows)
                  if portable_run_id(path.stem) != path.stem]
    if unportable:
        warnings.warn(f"{len(unportable)} file name(s) cannot name a run's folder on Windows (a device name such as "
                      "con or nul, a trailing dot or blank, or one of <>:\"|?*), so their run ids differ from them: "
                      f"{'; '.join(unportable[:5])}{' ...' if len(unportable) > 5 else ''}", RoadtexWarning, stacklevel=2)
    renamed = [f"{path.relative_to(root).as_posix()} -> {row['run_id']}" for path, row in zip(files, rows)
               if row["run_id"] != portable_run_id(path.stem)]
    if renamed:
        warnings.warn(f"{len(renamed)} file(s) share a name (whatever the case) with another file of the folder, so "
                      "their run ids are "
                      f"made from their paths: {'; '.join(renamed[:5])}{' ...' if len(renamed) > 5 else ''}",
                      RoadtexWarning, stacklevel=2)
    table = pl.DataFrame(rows, infer_schema_length=None)
    return read_manifest(table, base_dir=root)


def metadata_cell(name: str, value: Any, file: str) -> Any:
    """A file's metadata value as its manifest cell: the text columns (site, date, ...) hold text,
    so a number is written as such and a list or object (a sidecar's, any JSON) as its JSON text:
    one file's [1, 2] beside another's "S1" made polars refuse the whole table. A speed that is
    not a number is left empty, with a warning naming the file."""
    if name == "speed_kmh":
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
        warnings.warn(f"{file}: its metadata's speed_kmh {str(value)[:40]!r} is not a number: its manifest cell is "
                      "left empty (write the speed there, in km/h)", RoadtexWarning, stacklevel=3)
        return None
    if isinstance(value, str):
        return value
    return json.dumps(value) if isinstance(value, (list, dict)) else str(value)


def folder_name_problem(run_id: str) -> str | None:
    """Why ``run_id`` cannot name a folder on every system (Windows strips a trailing dot or blank,
    refuses the characters of :data:`WINDOWS_FORBIDDEN` and reserves device names,
    :data:`RESERVED_NAMES`), or None."""
    forbidden = sorted({c for c in run_id if c in WINDOWS_FORBIDDEN})
    if forbidden:
        return f"holds {' '.join(forbidden)}, which no folder name on Windows may hold"
    if run_id.endswith((".", " ")):
        return "ends in a dot or a blank, which Windows strips from a folder's name (two runs would share one)"
    if run_id.split(".")[0].rstrip(" ").lower() in RESERVED_NAMES:
        return "is a name Windows reserves for a device (con, prn, aux, nul, com1-com9, lpt1-lpt9, with any suffix)"
    return None


def portable_run_id(stem: str) -> str:
    """A file's name without suffix as a run id every system's folders take
    (:func:`folder_name_problem`): a trailing dot or blank replaced by '_', '_' added after a
    reserved device name (``con`` -> ``con_``), each character Windows refuses in a name by '_'."""
    stem = "".join("_" if c in WINDOWS_FORBIDDEN else c for c in stem)
    name = stem.rstrip(". ")
    name = name + "_" if name != stem or not name else name
    head, dot, tail = name.partition(".")
    return f"{head}_{dot}{tail}" if folder_name_problem(name) is not None else name


def unique_run_id(path: Path, root: Path, rows: list[dict[str, Any]]) -> str:
    """The file's name without suffix (:func:`portable_run_id`); if an earlier file (in sorted order)
    took it, whatever the case, its path in the folder joined by '_'; if that is taken too
    (``a/x.csv``, ``a_x.csv``, ``x.csv``), that with the first free suffix ``-2``, ``-3``, ...
    (deterministic: the files are listed sorted)."""
    taken = {r["run_id"].casefold() for r in rows}   # A and a name one folder on Windows and macOS
    own = portable_run_id(path.stem)
    if own.casefold() not in taken:
        return own
    joined = portable_run_id("_".join(path.relative_to(root).with_suffix("").parts))
    candidate, number = joined, 1
    while candidate.casefold() in taken:
        number += 1
        candidate = f"{joined}-{number}"
    return candidate
