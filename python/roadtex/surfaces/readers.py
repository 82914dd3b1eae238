"""Reading road surface files: 2-D ``.npy``, long tables (x, y, z) in Parquet or CSV, OpenCRG ``.crg``,
ISO 25178-72 ``.x3p`` (:mod:`roadtex.surfaces.x3p`)."""

from __future__ import annotations

import io
import re
import warnings
from pathlib import Path

import numpy as np
import polars as pl

from roadtex._checks import positive
from roadtex.errors import InvalidInputError, MissingDependencyError, ProfileFormatError, UnitConflictWarning
from roadtex.profiles.conditioning import format_number
from roadtex.profiles.plausibility import (
    set_distance_unit,
    stated_distance_unit,
    warn_if_implausible_across,
    warn_if_implausible_texture,
)
from roadtex.profiles.profile import MAX_MAGNITUDE
from roadtex.profiles.readers import DX_CONFLICT, file_head, guess_format
from roadtex.profiles.readers.delimited import is_number, sniff_decimal, sniff_separator
from roadtex.profiles.readers.limits import check_parquet_points, check_points
from roadtex.profiles.readers.npy import load_numeric_npy, npy_header, read_sidecar
from roadtex.profiles.readers.text import (
    DROPOUT_TOKENS,
    bare_interval_unit,
    column_unit,
    first_lines,
    pick_column,
    split_column_name,
    stated_unit,
)
from roadtex.profiles.units import unit_factor
from roadtex.surfaces.surface import Surface
from roadtex.surfaces.x3p import read_x3p_grid

#: Formats :func:`read_surface` reads.
SURFACE_FORMATS = ("crg", "csv", "npy", "parquet", "x3p")
#: The options :func:`read_surface` takes, with their types (for a bulk job's manifest columns).
SURFACE_READ_OPTIONS: dict[str, type] = {
    "dx": float, "dy": float, "height_unit": str, "distance_unit": str, "x_column": str, "y_column": str,
    "z_column": str,
}
#: Column names recognised in long tables, by role (case and units ignored).
X_NAMES = ("x", "distance", "position", "longitudinal", "along", "chainage", "u")
Y_NAMES = ("y", "lateral", "transverse", "across", "offset", "v")
Z_NAMES = ("z", "height", "elevation", "h", "texture")
#: Grid positions must sit within this fraction of a spacing of a grid node (text exports round
#: positions: 0.0375 mm steps written to 0.001 mm are up to 1.3 % off the grid, 0.01 mm steps 5 %).
GRID_TOLERANCE = 0.1
#: Where a long table's column options are given (the bulk job finds columns by name only).
WHERE_COLUMNS = "a read_surface option; the bulk job finds x, y, z by name: rename the column in the file"
#: Cells read as drop-outs (missing heights) in CSV long tables, as the profile reader reads them.
NULL_TOKENS = sorted({token for t in DROPOUT_TOKENS for token in (t, t.upper(), t.capitalize())} | {"NaN"})


def blank_fields(line: str) -> list[str]:
    """The fields of a blank-separated line; a unit in brackets after a name stays with it
    (``x (mm) y (mm) z (mm)`` is three names)."""
    return re.findall(r"[^\s\(\[]+(?:\s*[\(\[][^\)\]]*[\)\]])?|[\(\[][^\)\]]*[\)\]]", line)


def tab_separated(data: bytes, header: bool) -> bytes:
    """Blank-separated text (an x y z point list) as tab-separated text; the header (the first line
    that is neither blank nor a ``#`` comment) split by :func:`blank_fields`."""
    lines = data.split(b"\n")
    first = next((i for i, line in enumerate(lines) if line.strip() and not line.lstrip().startswith(b"#")), None)
    body = re.sub(rb"[ \t]+", b"\t", re.sub(rb"(?m)^[ \t]+|[ \t]+(?=\r?$)", b"", data))
    if not header or first is None:
        return body
    out = body.split(b"\n")
    out[first] = "\t".join(blank_fields(lines[first].decode("utf-8", "replace").strip())).encode()
    return b"\n".join(out)


def is_surface_file(path: str | Path) -> bool:
    """Whether a file holds a 3-D surface rather than a line profile, from its structure alone:
    an OpenCRG file, a 2-D ``.npy`` that is not (N, 2) distance/height pairs, or a table (CSV,
    TSV, Parquet) whose header names an x, a y and a z column (see :data:`X_NAMES` ...).
    Unreadable files are not surfaces (the profile reader then says why)."""
    file = Path(path)
    try:
        head = file_head(file, 4096)
        fmt = guess_surface_format(file, head)
        if fmt in ("crg", "x3p"):
            return True
        if fmt == "npy":
            shape, _ = npy_header(file, file.name)   # the header alone: no 16 GB map of a sparse file
            return len(shape) == 2 and shape[0] > 1 and shape[1] > 2
        if fmt == "parquet":
            names = pl.read_parquet_schema(file).names()
        else:
            if guess_format(file, head) == "captif":
                return False
            lines, _ = first_lines(head.removeprefix(b"\xef\xbb\xbf"), 50)
            data_lines = [line for line in lines if line.strip() and not line.lstrip().startswith(b"#")]
            separator = sniff_separator(data_lines)
            if not data_lines:
                return False
            text = data_lines[0].decode("utf-8", "replace")
            names = blank_fields(text) if separator == " " else [f.strip().strip('"') for f in text.split(separator)]
    except Exception:  # noqa: BLE001 - not readable as a surface: the profile reader reports it
        return False
    bases = [split_column_name(n)[0] for n in names]
    return all(any(s in bases for s in synonyms) for synonyms in (X_NAMES, Y_NAMES, Z_NAMES))


def guess_surface_format(path: Path, head: bytes) -> str:
    """The format of a file from its first bytes, then its suffix (CSV when nothing else fits)."""
    if head.startswith(b"\x93NUMPY"):
        return "npy"
    if head.startswith(b"PAR1"):
        return "parquet"
    suffix = path.suffix.lower()
    if suffix == ".x3p":
        return "x3p"
    if suffix == ".crg" or head.lstrip().startswith((b"$CT", b"$ROAD_CRG", b"$KD_DEFINITION", b"$!")):
        return "crg"
    if suffix in (".parquet", ".pq"):
        return "parquet"
    return "csv"


def read_surface(path: str | Path, format: str | None = None, *, dx: float | None = None, dy: float | None = None,
                 height_unit: str | None = None, x_column: str | int | None = None, y_column: str | int | None = None,
                 z_column: str | int | None = None, distance_unit: str | None = None) -> Surface:
    """Reads a road surface file into a :class:`Surface` in metres, drop-outs as NaN.

    Formats (``format=None`` guesses from the content, then the suffix):

    - ``"npy"``: a 2-D array ``heights[iy, ix]`` (rows across the road, columns along it); the
      spacings ``dx`` (along) and ``dy`` (across, default ``dx``) in m are arguments (the bulk job
      passes its manifest columns), heights in metres unless ``height_unit`` says otherwise. A
      ``<file>.npy.json`` sidecar may hold ``dx``, ``dy``, ``height_unit``, ``metadata``, ``history``.
    - ``"parquet"`` or ``"csv"``: a long table with one row per reading and columns x (along), y
      (across) and z (height), found by name (x, distance, position / y, lateral, transverse /
      z, height, elevation) or given as ``x_column``, ``y_column``, ``z_column``. Units come from
      the header (``"x (mm)"``, ``"z [um]"``, ``"z_mm"``) or ``distance_unit`` / ``height_unit``.
      The positions must lie on a regular grid (grid nodes without a row are drop-outs); the
      spacings are found from the data (``dx``, ``dy`` override them). CSV: the separator (tab,
      ``;``, ``,``, or blanks: an ``x y z`` point list) and a decimal comma are sniffed; ``#`` lines
      are comments; without a header the columns are x, y, z in that order.
    - ``"crg"``: ASAM OpenCRG through the ``pycrg`` package (``pip install pycrg``), which wraps the
      reference C library; all four data formats. The grid is read as stored (no modifiers applied)
      and ``z`` is taken relative to the reference line (its slope, banking and curvature are the
      road's geometry, not its texture): u along the road is x, v across is y (rows from right to
      left, v increasing).
    - ``"x3p"``: ISO 25178-72 (a zip of ``main.xml`` and binary data, :mod:`roadtex.surfaces.x3p`):
      spacings and origin from the X and Y axes' increments and offsets, heights from the Z data
      (int16, int32, float32, float64, scaled by its increment), all in metres as the format
      states; invalid points (NaN, the valid-points mask) are drop-outs. ``dx``, ``dy`` and
      ``height_unit`` are the file's and cannot be given.

    Warns:
        ImplausibleTextureWarning: heights or spacings that cannot be a road texture in metres
            (millimetres read as metres or as micrometres, distances in millimetres read as
            metres), judged along each row without drop-out codes, as :func:`roadtex.read_profile` does;
            a spacing dx above 5 mm only where its unit is assumed (a ``.npy``'s or a given ``dx``);
            rows across further apart than 0.5 m or spread over more than 5 m
            (:func:`~roadtex.profiles.plausibility.implausible_across`), whatever the unit.
        CoarseSamplingWarning: dx above 5 mm whose unit is certain (OpenCRG, which is in metres by
            definition, or a long table's positions with their unit stated or given): read as it is.

    Raises:
        ProfileFormatError: the file is missing, empty, unreadable, not a grid, or has no usable
            column (the message names the file).
        InvalidInputError: an unknown format or unit, or a bad spacing.
        MissingDependencyError: a ``.crg`` file without ``pycrg`` installed.
    """
    file = Path(path)
    name = file.name
    if format is not None and format not in SURFACE_FORMATS:
        raise InvalidInputError(f"unknown surface format {format!r}; known formats: {', '.join(SURFACE_FORMATS)}")
    head = file_head(file, 4096)
    fmt = format or guess_surface_format(file, head)
    options = {"dx": dx, "dy": dy, "height_unit": height_unit, "distance_unit": distance_unit,
               "x_column": x_column, "y_column": y_column, "z_column": z_column}
    try:
        if fmt == "npy":
            surface = read_npy_surface(file, name, options)
        elif fmt == "crg":
            surface = read_crg(file, name, options)
        elif fmt == "x3p":
            surface = read_x3p(file, name, options)
        else:
            surface = read_long_table(file, name, fmt, options)
    except (ProfileFormatError, InvalidInputError) as exc:
        if str(exc).startswith(name):
            raise
        raise type(exc)(f"{name}: {exc}") from None
    # as read_profile: heights or spacings in the wrong unit warn (the bulk job refuses the run)
    warn_if_implausible_texture(surface.heights, surface.dx, name, stacklevel=3, row="surface row", measured=True,
                                stated=stated_distance_unit(surface.metadata))
    warn_if_implausible_across(surface.dy, surface.shape[0], name, stacklevel=3)
    return surface


def finish(name: str, fmt: str, heights: np.ndarray, dx: float, dy: float, metadata: dict, history: list[str],
           x0: float = 0.0, y0: float = 0.0) -> Surface:
    """The :class:`Surface` a reader found (heights m, spacings and origin m), with its history line."""
    if np.isinf(heights).any():
        raise ProfileFormatError(f"{name}: holds an infinite or overflowing height")
    if np.isnan(heights).all():
        raise ProfileFormatError(f"{name}: all {heights.size} heights are drop-outs (NaN)")
    biggest = float(np.nanmax(np.abs(heights)))
    if biggest > MAX_MAGNITUDE:   # the file's fault, not an argument's: a ProfileFormatError naming it
        raise ProfileFormatError(f"{name}: a height of {biggest:.3g} m is beyond {MAX_MAGNITUDE:.0g} m: not a road "
                                 "surface (a corrupt file, or the wrong height unit?)")
    metadata.setdefault("source", name)
    history.append(f"read_surface({name!r}, format={fmt!r}): {heights.shape[0]} x {heights.shape[1]} readings, "
                   f"dx {format_number(dx)} m, dy {format_number(dy)} m, "
                   f"{int(np.count_nonzero(np.isnan(heights)))} drop-outs")
    return Surface(heights, dx, dy, metadata, tuple(history), x0, y0)


def read_npy_surface(path: Path, name: str, options: dict) -> Surface:
    """A 2-D ``.npy`` array and its optional JSON sidecar; see :func:`read_surface`."""
    array = load_numeric_npy(path, name)
    if array.ndim != 2 or array.shape[1] < 2:
        raise ProfileFormatError(f"{name}: a surface .npy must be 2-D [rows across, columns along] with at least "
                                 f"2 columns, got shape {array.shape} (a line profile? use read_profile)")
    if array.shape[1] == 3 and array.shape[0] > 3:
        raise ProfileFormatError(f"{name}: shape {array.shape}: an x, y, z point list? A surface .npy is a grid "
                                 "heights[iy, ix] (rows across the road, columns along it); write the points as a "
                                 "long table (CSV or Parquet with x, y, z columns)")
    metadata, history, options, sources = read_sidecar(path, options, ("dx", "dy", "height_unit", "distance_unit"))
    if options.get("dx") is None:
        raise InvalidInputError(f"a .npy surface needs dx (m, the spacing along the road; dy across defaults to dx): "
                                f"give it as read_surface's dx, the bulk job's manifest columns dx and dy, or a "
                                f"{name}.json sidecar ({{\"dx\": ..., \"dy\": ...}})")
    dx = positive(options["dx"], "dx")
    dy = positive(options["dy"], "dy") if options.get("dy") is not None else dx
    factor = unit_factor(options.get("height_unit") or "m", "the .npy heights")
    # dx is a bare number (m): certain when m is given for the file, else assumed
    set_distance_unit(metadata, bare_interval_unit(options.get("distance_unit"),
                                                  sources.get("distance_unit", "")))
    return finish(name, "npy", array.astype(np.float64) * factor, dx, dy, metadata, history)


def grid_index(values: np.ndarray, given: float | None, what: str, name: str) -> tuple[np.ndarray, float, float]:
    """Index of each position (m) on a regular grid, the spacing (m) and the first node (m); refuses
    non-grids. A spacing ``given`` (m) more than 1 % off the positions' own grid's is ignored with a
    :class:`~roadtex.errors.UnitConflictWarning`, as a profile's distances are kept: a job-wide
    ``--input-dx`` for heights-only files must neither refuse a table with positions nor spread it
    over a finer grid of empty nodes."""
    if given is None or np.unique(values).size < 2:
        return regular_grid(values, given, what, name)
    try:
        own = regular_grid(values, None, what, name)
    except ProfileFormatError:
        return regular_grid(values, given, what, name)   # off a grid of their own: the given spacing may place them
    if abs(own[1] - positive(given, f"d{what}")) > DX_CONFLICT * own[1]:
        warnings.warn(f"{name}: its {what} positions are {own[1]:.4g} m apart; the d{what} {given:g} m given is ignored "
                      "for it (a file's own positions are kept)", UnitConflictWarning, stacklevel=4)   # read_surface's caller
        return own
    return regular_grid(values, given, what, name)


def regular_grid(values: np.ndarray, given: float | None, what: str, name: str) -> tuple[np.ndarray, float, float]:
    """Index of each position on a regular grid, the spacing and the first node; refuses non-grids.

    Without ``given``, the spacing is the span over the number of grid steps (each gap between
    neighbouring positions counted in steps of their median gap), so positions rounded in a text
    export still give the grid's spacing."""
    unique = np.unique(values)
    if unique.size < 2 and given is None:
        raise ProfileFormatError(f"{name}: every {what} position is {unique[0]:.6g} m: give the spacing d{what}")
    start = float(unique[0])
    if given is not None:
        step = positive(given, f"d{what}")
    else:
        gaps = np.diff(unique)
        steps = np.maximum(np.rint(gaps / np.median(gaps)), 1.0)
        step = float((unique[-1] - unique[0]) / steps.sum())
        if unique.size > 2:   # the least-squares line through (node, position): rounding averages out
            nodes = np.concatenate([[0.0], np.cumsum(steps)])
            mean_n, mean_u = float(np.sum(nodes)) / nodes.size, float(np.sum(unique)) / unique.size
            step = float(np.sum((nodes - mean_n) * (unique - mean_u)) / np.sum((nodes - mean_n) ** 2))
            start = mean_u - step * mean_n
    scaled = (values - start) / step
    index = np.rint(scaled)
    off = np.abs(scaled - index)
    if off.max() > GRID_TOLERANCE:
        bad = int(np.argmax(off))
        raise ProfileFormatError(f"{name}: not a regular grid: {what} = {values[bad]:.9g} m is not a multiple of "
                                 f"the spacing {step:.6g} m from {start:.9g} m (give d{what}, or resample the "
                                 "data onto a grid first)")
    return index.astype(np.int64), step, start


def read_long_table(path: Path, name: str, fmt: str, options: dict) -> Surface:
    """A Parquet or CSV table of (x, y, z) readings on a grid; see :func:`read_surface`."""
    try:
        if fmt == "parquet":
            check_parquet_points(path, name)   # before polars allocates it: it aborts the process when it cannot
            frame = pl.read_parquet(path)
        else:
            lines, _ = first_lines(path.read_bytes()[:65536].removeprefix(b"\xef\xbb\xbf"), 50)
            data_lines = [line for line in lines if line.strip() and not line.lstrip().startswith(b"#")]
            separator = sniff_separator(data_lines)
            source: Path | io.BytesIO = path
            if separator == " ":   # an x y z point list: blanks between the fields
                first = blank_fields(data_lines[0].decode("utf-8", "replace")) if data_lines else []
                header = not all(is_number(f) or is_number(f, ",") for f in first)
                source = io.BytesIO(tab_separated(path.read_bytes().removeprefix(b"\xef\xbb\xbf"), header))
                separator = "\t"
                data_lines = [re.sub(rb"[ \t]+", b"\t", line.strip()) for line in data_lines]
                if header:
                    data_lines[0] = "\t".join(first).encode()
            decimal = sniff_decimal(data_lines[1:6] or data_lines[:1], separator)
            first = [f.strip().strip('"') for f in data_lines[0].decode("utf-8", "replace").split(separator)]
            header = not all(is_number(f, decimal) for f in first)
            if header and len(data_lines) > 1:
                fields = len(data_lines[1].split(separator.encode()))
                if fields != len(first):
                    raise ProfileFormatError(f"{name}: the header {first} has {len(first)} fields but the first data "
                                             f"row has {fields} with the separator {separator!r}: the file mixes "
                                             "separators or decimal marks")
            frame = pl.read_csv(source, separator=separator, comment_prefix="#", null_values=NULL_TOKENS,
                                infer_schema_length=10000, decimal_comma=decimal == ",", has_header=header)
            if not header:
                frame.columns = [f"column_{i + 1}" for i in range(frame.width)]
    except ProfileFormatError:
        raise
    except Exception as exc:
        message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ProfileFormatError(f"{name}: not a readable {fmt} table: {message}") from None
    if frame.height == 0:
        raise ProfileFormatError(f"{name}: the table has no rows")
    names = frame.columns
    headerless = fmt != "parquet" and not header
    if headerless and frame.width != 3 and not all(options.get(f"{r}_column") is not None for r in "xyz"):
        grid = (f"; {frame.width} columns: a grid of heights (one line per row across the road)? Save it as a 2-D "
                ".npy (numpy.save) and give dx and dy" if frame.width > 3 else "")
        raise ProfileFormatError(f"{name}: no header, and not 3 columns (x, y, z in that order){grid}. read_surface "
                                 "reads long tables (one row per reading: x along, y across, z), 2-D .npy and OpenCRG")
    picked = []
    for role, synonyms in (("x", X_NAMES), ("y", Y_NAMES), ("z", Z_NAMES)):
        given = options.get(f"{role}_column")
        try:
            index = pick_column(names, "xyz".index(role) if headerless and given is None else given, synonyms, role,
                                True, where=WHERE_COLUMNS)
        except ProfileFormatError:
            if frame.width > 3 and not any(split_column_name(n)[0] in X_NAMES + Y_NAMES + Z_NAMES for n in names):
                raise ProfileFormatError(
                    f"{name}: {frame.width} columns and none named x, y or z (the first: {names[:3]}): a grid of "
                    "heights (one line per row across the road)? read_surface reads long tables (one row per "
                    "reading: x along, y across, z), 2-D .npy (save the grid with numpy.save and give dx and dy) "
                    "and OpenCRG") from None
            raise
        assert index is not None
        picked.append(index)
    if len(set(picked)) < 3:
        raise ProfileFormatError(f"{name}: x, y and z must be three different columns, got {[names[i] for i in picked]}")
    roles = (("distance", "x", picked[0]), ("distance", "y", picked[1]), ("height", "z", picked[2]))
    missing = [(what, names[i]) for what, _, i in roles
               if options.get(f"{what}_unit") is None and split_column_name(names[i])[1] is None]
    if missing:
        kinds = sorted({what for what, _ in missing})
        columns = " and ".join(f"the {kind} column{'s' if len(cs) > 1 else ''} {', '.join(map(repr, cs))}"
                               for kind in kinds for cs in [[c for w, c in missing if w == kind]])
        raise ProfileFormatError(
            f"{name}: no unit for {columns} (the file states none): give {' and '.join(k + '_unit' for k in kinds)} "
            f"('m', 'mm', 'um', ...) as a read_surface option, a manifest column or roadtex process "
            f"{', '.join('--' + k + '-unit' for k in kinds)}")

    def column(index: int) -> np.ndarray:
        series = frame.get_column(names[index])
        if not series.dtype.is_numeric():
            bad = series.cast(pl.Float64, strict=False).is_null() & series.is_not_null()
            first_bad = series.filter(bad).head(1).to_list()
            raise ProfileFormatError(f"{name}: column {names[index]!r} is {series.dtype}, not numeric"
                                     + (f" (it holds {first_bad[0]!r})" if first_bad else ""))
        return series.cast(pl.Float64).fill_null(float("nan")).to_numpy()

    x, y, z = (column(i) * column_unit(names, i, options.get(f"{what}_unit"), what) for what, _, i in roles)
    if not (np.isfinite(x).all() and np.isfinite(y).all()):
        raise ProfileFormatError(f"{name}: x and y must be finite on every row (drop-outs are missing z)")
    ix, dx, x0 = grid_index(x, options.get("dx"), "x", name)
    iy, dy, y0 = grid_index(y, options.get("dy"), "y", name)
    shape = (int(iy.max()) + 1, int(ix.max()) + 1)
    if shape[0] * shape[1] > 50 * x.size:
        raise ProfileFormatError(f"{name}: the positions span a grid of {shape[0]} x {shape[1]} nodes for only "
                                 f"{x.size} readings: not a grid")
    check_points(name, shape[0] * shape[1], f"its positions' grid of {shape[0]:,} x {shape[1]:,} nodes")
    flat = iy * shape[1] + ix
    if np.unique(flat).size != flat.size:
        raise ProfileFormatError(f"{name}: duplicate (x, y) positions: a grid has one reading per node")
    heights = np.full(shape[0] * shape[1], np.nan)
    heights[flat] = z
    metadata: dict[str, object] = {"format": fmt}
    # x's unit is the header's or the given one (required above); a dx given is kept only within 1 %
    # of the positions' own spacing (grid_index)
    set_distance_unit(metadata, stated_unit(names, picked[0], options.get("distance_unit")))
    return finish(name, fmt, heights.reshape(shape), dx, dy, metadata, [], x0, y0)


def read_crg(path: Path, name: str, options: dict) -> Surface:
    """An OpenCRG file through pycrg (heights relative to the reference line); see :func:`read_surface`."""
    try:
        import pycrg
    except ImportError:
        raise MissingDependencyError(f"{name}: reading OpenCRG (.crg) files needs the pycrg package "
                                     "(pip install pycrg, or roadtex[crg]; it wraps the ASAM OpenCRG C library)") from None
    try:
        with pycrg.DataSet.open(str(path), apply_modifiers=False) as dataset:
            grid = dataset.grid()
            du, dv = dataset.increments()
            header = dataset.header
    except Exception as exc:
        message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ProfileFormatError(f"{name}: not a readable OpenCRG file: {message}") from None
    v = np.asarray(grid.v, dtype=np.float64)
    check_crg_header(name, header, np.asarray(grid.u, dtype=np.float64), v, float(du))
    if v.size > 1:
        steps = np.diff(v)
        if np.ptp(steps) > GRID_TOLERANCE * float(np.mean(steps)):
            raise ProfileFormatError(f"{name}: the long sections are not equally spaced across the road "
                                     f"(v from {v[0]:.6g} to {v[-1]:.6g} m); a Surface needs a regular grid")
        dy = float(np.mean(steps)) if options.get("dy") is None else positive(options["dy"], "dy")
    else:
        dy = positive(options["dy"], "dy") if options.get("dy") is not None else float(du)
    dx = float(du) if options.get("dx") is None else positive(options["dx"], "dx")
    factor = unit_factor(options.get("height_unit") or "m", "the CRG heights")
    heights = np.asarray(grid.z, dtype=np.float64).T * factor
    metadata: dict[str, object] = {"format": "crg", "crg_data_format": str(getattr(header, "data_format", "")),
                                   "crg_comment": "\n".join(getattr(header, "comment", None) or [])}
    # OpenCRG is in metres by definition; a dx given instead of the file's increment is a bare number
    set_distance_unit(metadata, "m (OpenCRG)" if options.get("dx") is None else None)
    return finish(name, "crg", heights, dx, dy, metadata, [], float(grid.u[0]), float(v[0]))


def check_crg_header(name: str, header: object, u: np.ndarray, v: np.ndarray, du: float) -> None:
    """Refuses an OpenCRG header that contradicts its data or itself, naming both figures.

    The OpenCRG library places the data by the header's start and increment and ignores the ends
    it states (``reference_line_end_u``, ``long_section_v_left``) and the increment the U channel
    of ``$KD_DEFINITION`` repeats: a wrong increment (1e-9 m), a truncated data section or a sign
    slip would be read as stated, without a word. Each end stated must be where the number of
    cross sections (long sections) at the increment puts the last one, within half an increment."""
    road = getattr(header, "road", None) or {}

    def stated(key: str) -> float | None:
        value = road.get(key)
        return float(value) if isinstance(value, (int, float)) else None

    if not (np.isfinite(du) and du > 0):
        raise ProfileFormatError(f"{name}: reference_line_increment is {du:g} m: the spacing along the road must be a "
                                 "positive number of metres")
    if not (np.isfinite(u[[0, -1]]).all() and np.isfinite(v).all()):
        raise ProfileFormatError(f"{name}: the header places the data at u from {u[0]:g} to {u[-1]:g} m, v from "
                                 f"{v[0]:g} to {v[-1]:g} m: not finite (reference_line_start_u, long_section_v_*)")
    end_u = stated("reference_line_end_u")
    if end_u is not None and abs(end_u - u[-1]) > du / 2:
        raise ProfileFormatError(
            f"{name}: the header contradicts its data: reference_line_end_u is {end_u:g} m, but its {u.size} cross "
            f"sections from {u[0]:g} m at reference_line_increment {du:g} m end at {u[-1]:g} m (a truncated data "
            "section, or a wrong increment or end)")
    channel_u = next((c for c in getattr(header, "channels", ()) if getattr(c, "kind", "") == "U"), None)
    extra = getattr(channel_u, "extra", ())
    if len(extra) >= 2 and is_number(str(extra[1]).strip()) and abs(float(extra[1]) - du) > 1e-6 * du:
        raise ProfileFormatError(f"{name}: the header contradicts itself: reference_line_increment is {du:g} m, the "
                                 f"U channel's increment ($KD_DEFINITION) {float(extra[1]):g} m")
    if v.size > 1:
        steps = np.diff(v)
        if not (steps > 0).all():
            raise ProfileFormatError(f"{name}: the long sections' v runs from {v[0]:g} to {v[-1]:g} m, not increasing "
                                     "from right to left (long_section_v_increment must be positive)")
        v_left = stated("long_section_v_left")
        if v_left is not None and abs(v_left - v[-1]) > float(np.mean(steps)) / 2:
            raise ProfileFormatError(
                f"{name}: the header contradicts its data: long_section_v_left is {v_left:g} m, but its {v.size} long "
                f"sections from {v[0]:g} m at long_section_v_increment {float(np.mean(steps)):g} m end at "
                f"{v[-1]:g} m")


def read_x3p(path: Path, name: str, options: dict) -> Surface:
    """An ISO 25178-72 X3P surface; see :func:`read_surface` and :mod:`roadtex.surfaces.x3p`."""
    given = [key for key in ("dx", "dy", "height_unit", "distance_unit") if options.get(key) is not None]
    if given:
        raise InvalidInputError(f"{name}: an X3P file states its spacings and units (SI) itself; "
                                f"{', '.join(given)} cannot be given")
    heights, dx, dy, x0, y0, metadata = read_x3p_grid(path, name)
    set_distance_unit(metadata, "m (X3P)")
    return finish(name, "x3p", heights, dx, dy, metadata, [], x0, y0)
