"""Reading road profile files: one module per format, :func:`read_profile` picks the format."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from roadtex._checks import finite_number, positive
from roadtex.errors import InvalidInputError, ProfileFormatError, UnitConflictWarning
from roadtex.profiles.conditioning import distance_jumps, format_number, missing_positions
from roadtex.profiles.plausibility import stated_distance_unit, warn_if_implausible_texture
from roadtex.profiles.profile import MAX_MAGNITUDE, Profile
from roadtex.profiles.readers.captif import CAPTIF_MARKER, read_captif
from roadtex.profiles.readers.delimited import read_delimited
from roadtex.profiles.readers.npy import read_npy
from roadtex.profiles.readers.parquet import read_parquet
from roadtex.profiles.readers.screening import refuse_restarts
from roadtex.profiles.readers.text import decode_text, nominal_dx, refuse_binary, sorted_samples

#: A dx given for a file with distances that differs from their interval by more than this share
#: is ignored, with a warning: the file's distances are kept.
DX_CONFLICT = 0.01
#: Formats :func:`read_profile` reads.
FORMATS = ("captif", "csv", "npy", "parquet")
#: The options :func:`read_profile` takes, with their types (the bulk job's manifest columns of
#: the same names carry them per run).
READ_OPTIONS: dict[str, type] = {
    "distance_column": str, "height_column": str, "distance_unit": str, "height_unit": str, "dx": float,
    "start": float, "delimiter": str, "decimal": str, "encoding": str, "sort": bool, "dropout_value": float,
}


def guess_format(path: Path, head: bytes) -> str:
    if head.startswith(b"\x93NUMPY"):
        return "npy"
    if head.startswith(b"PAR1"):
        return "parquet"
    suffix = path.suffix.lower()
    if suffix == ".npy":
        return "npy"
    if suffix in (".parquet", ".pq"):
        return "parquet"
    if CAPTIF_MARKER in head or CAPTIF_MARKER in utf16_ascii(head):
        return "captif"
    return "csv"


def file_head(file: Path, size: int = 8192) -> bytes:
    """The first ``size`` bytes of a data file, which must exist and not be empty (to guess its format)."""
    if not file.is_file():
        if file.exists():
            raise ProfileFormatError(f"{file} is not a regular file (a folder, a device or a pipe): a run must be a "
                                     "profile or surface file")
        raise ProfileFormatError(f"no such file: {file}")
    if file.stat().st_size == 0:
        raise ProfileFormatError(f"{file.name} is empty")
    with file.open("rb") as handle:
        return handle.read(size)


def utf16_ascii(head: bytes) -> bytes:
    return head.replace(b"\x00", b"")


def read_profile(path: str | Path, format: str | None = None, **options: object) -> Profile:
    """Reads a road profile file into a :class:`Profile` in metres, drop-outs as NaN.

    Formats (``format=None`` guesses from the content, then the suffix):

    - ``"captif"``: the CAPTIF stationary laser profilometer text file: tab-separated metadata
      lines, ``*****DATA*****``, a header ``Data Point No: / Distance (mm) / Depth (mm)``, rows of
      point, distance, height. The third column is a height, positive up, whatever its name.
      Metadata (site, wheel_path, direction, date as ISO yyyy-mm-dd, file_number, ...) is kept.
    - ``"csv"``: delimited text (``.csv``, ``.tsv``, ``.txt``, ...): the delimiter (tab, ``;``,
      ``,`` or blanks) is sniffed, a header is detected. Columns are found by name (distance,
      position, x, chainage / height, z, elevation, profile) or given; units come from the header
      (``"height (mm)"``, ``"height [um]"``, ``"z_mm"``) or are given. Leading ``# key: value``
      lines become metadata. Without a header, the first column is distance and the second height.
      Empty fields are drop-outs.
    - ``"npy"``: 1-D heights (needs ``dx``) or (N, 2) distance/height pairs, in metres unless units
      are given; a ``<file>.npy.json`` sidecar written by :func:`write_profile` adds metadata.
    - ``"parquet"``: a table with distance and height columns, found and scaled as for CSV.

    Options: ``distance_column``, ``height_column`` (name or index), ``distance_unit``,
    ``height_unit`` (``"m"``, ``"mm"``, ``"um"``, ...), ``dx`` (m, for heights-only data; also the
    nominal dx to record, within 1 % of the interval of a file's own distances: one further off is
    ignored with a :class:`~roadtex.errors.UnitConflictWarning`), ``start`` (m, first position for heights-only data), ``delimiter``,
    ``decimal`` (``"."`` or ``","``; a decimal comma is recognised in ``;``- or tab-separated
    files when every comma in the first rows sits inside a number), ``encoding`` (text files;
    UTF-8, UTF-16 with a byte-order mark and Latin-1 are recognised),
    ``sort`` (default True: out-of-order rows are sorted by position; False refuses them),
    ``dropout_value`` (text files: the number the file writes for a missing reading, in its height
    unit, e.g. -9999; those readings become drop-outs, counted in the history. The codes -9999,
    -999, 9999 and -99999 are recognised without it where they repeat as no texture does).

    Rows are sorted by position; exact duplicates that agree are merged. Distances that go back
    by a large share of the run (a second run appended, restarting at 0) are refused.

    Warns:
        ImplausibleTextureWarning: heights or an interval that cannot be a road texture in metres
            (heights in mm or um read as m; distances in mm read as m: above 5 mm), the latter only
            where the distances' unit was assumed (a .npy's metres, a bare ``dx``).
        CoarseSamplingWarning: an interval above 5 mm whose unit is certain (stated by the
            header or the format, or given): read as it is; the metadata's
            ``distance_unit_stated`` says where the unit comes from.

    Raises:
        ValueError: the file is missing, empty, binary or in an unknown encoding, truncated, has no
            usable distance or height column or an unknown unit, holds only drop-outs, or has
            duplicate positions with conflicting heights (the message names the problem).
    """
    file, name, fmt = opened(path, format, options)
    try:
        return read_as(file, name, fmt, options)
    except (ProfileFormatError, InvalidInputError) as exc:
        raise named(exc, name) from None


def opened(path: str | Path, format: str | None, options: dict[str, object]) -> tuple[Path, str, str]:
    """The file, its name and its format (given, else guessed), the options checked."""
    file = Path(path)
    unknown = set(options) - set(READ_OPTIONS)
    if unknown:
        raise InvalidInputError(f"unknown option(s) {sorted(unknown)}; known: {sorted(READ_OPTIONS)}")
    if options.get("dropout_value") is not None:
        options["dropout_value"] = finite_number(options["dropout_value"], "dropout_value")
    if format is not None and format not in FORMATS:
        raise InvalidInputError(f"unknown format {format!r}; known formats: {', '.join(FORMATS)}")
    head = file_head(file)
    return file, file.name, format or guess_format(file, head)


def named(exc: ProfileFormatError | InvalidInputError, name: str) -> ProfileFormatError | InvalidInputError:
    """``exc`` with a message that names the file, whichever helper raised it."""
    return exc if str(exc).startswith(name) else type(exc)(f"{name}: {exc}")


def read_as(file: Path, name: str, fmt: str, options: dict[str, object]) -> Profile:
    """Reads ``file`` in format ``fmt``; see :func:`read_profile` (it warns about heights that
    cannot be a road texture in the unit read, except inside
    :func:`~roadtex.profiles.plausibility.judged_once`)."""
    if fmt in ("npy", "parquet") and options.get("dropout_value") is not None:
        raise InvalidInputError(f"{name}: dropout_value is for text files (CSV, CAPTIF); a {fmt} file writes its "
                                "drop-outs as NaN")
    if fmt == "npy":
        positions, heights, metadata, history, dx = read_npy(file, name, options)
        encoding = None
    elif fmt == "parquet":
        positions, heights, metadata, history, dx = read_parquet(file, name, options)
        encoding = None
    else:
        if options.get("encoding") is None:
            refuse_binary(file_head(file), name)   # before reading it all
        data, encoding = decode_text(file.read_bytes(), options.get("encoding"), name)  # type: ignore[arg-type]
        reader = read_captif if fmt == "captif" else read_delimited
        positions, heights, metadata, history, dx = reader(data, name, options)
    if positions.size < 2:
        raise ProfileFormatError(f"{name}: {positions.size} data row(s): a profile needs at least 2")
    if np.isinf(heights).any() or np.isinf(positions).any():
        row = int(np.flatnonzero(np.isinf(heights) | np.isinf(positions))[0])
        raise ProfileFormatError(f"{name}: data row {row + 1} holds an infinite or overflowing value")
    if np.isnan(heights).all():
        raise ProfileFormatError(f"{name}: all {heights.size} heights are drop-outs (NaN)")
    biggest = float(max(np.nanmax(np.abs(heights)), np.nanmax(np.abs(positions))))
    if biggest > MAX_MAGNITUDE:   # the file's fault, not an argument's: a ProfileFormatError naming it
        raise ProfileFormatError(f"{name}: a height or position of {biggest:.3g} m is beyond {MAX_MAGNITUDE:.0g} m: "
                                 "not a road profile (a corrupt file, or the wrong unit?)")
    if not np.isnan(positions).any():
        refuse_restarts(positions, name)
    if options.get("sort", True) is False and np.any(np.diff(positions) <= 0):
        raise ProfileFormatError(f"{name}: positions are not strictly increasing (pass sort=True to sort them)")
    positions, heights, note = sorted_samples(positions, heights, name)
    if positions.size < 2:
        raise ProfileFormatError(f"{name}: fewer than 2 distinct positions")
    jumps = distance_jumps(positions)
    if jumps.size:   # before the interval is taken from the steps: a jump is no interval and no unit slip
        i = int(jumps[0])
        typical = float(np.median(np.diff(positions)))
        raise ProfileFormatError(
            f"{name}: the distances jump by {format_number(positions[i + 1] - positions[i])} m between readings "
            f"{i + 1} and {i + 2} by distance ({format_number(positions[i])} m to {format_number(positions[i + 1])} m), "
            f"where the readings are {format_number(typical)} m apart ({jumps.size} such jump(s)): two runs joined in "
            "one file, or a corrupt distance, not a unit mistake. Split the file at the jump (rows missing over a "
            "stretch no longer than the file's readings are read as drop-outs)")
    own = nominal_dx(positions)
    # (only a dx the caller gave: one stored by write_profile reads back as written)
    if options.get("dx") is not None and dx is not None and abs(positive(dx, "dx") - own) > DX_CONFLICT * own:
        # A job-wide --input-dx is for heights-only files: it must not redefine the interval of a
        # file whose distances state their own (the job would resample it at the wrong grid).
        warnings.warn(f"{name}: its distances are {own:.4g} m apart; the dx {dx:g} m given is ignored for it (a given "
                      "dx is the interval of heights-only files; a file's own distances are kept)",
                      UnitConflictWarning, stacklevel=3)   # the caller of read_profile
        dx = None
    dx_f = positive(dx, "dx") if dx is not None else own
    gaps = missing_positions(positions, dx_f).size
    if gaps:
        note += f"; {gaps} rows missing (gaps in the distances), drop-outs on the grid"
    metadata.setdefault("source", name)
    encoding_note = f", {encoding}" if encoding not in (None, "utf-8") else ""
    history.append(f"read_profile({name!r}, format={fmt!r}{encoding_note}): {positions.size} samples, "
                   f"dx {format_number(dx_f)} m, {int(np.count_nonzero(np.isnan(heights)))} drop-outs{note}")
    profile = Profile(heights, positions, dx_f, metadata, tuple(history))
    warn_if_implausible_texture(profile.heights, profile.dx, name, stacklevel=4, measured=True,
                                stated=stated_distance_unit(profile.metadata))
    return profile


__all__ = ["FORMATS", "READ_OPTIONS", "file_head", "guess_format", "read_profile"]
