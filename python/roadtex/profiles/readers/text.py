"""What the text readers share: decoding, finding columns and their units, parsing number tables,
and ordering samples. Every error raised here is a ProfileFormatError naming the file."""

from __future__ import annotations

import io
import math
import re
import warnings

import numpy as np
import polars as pl

from roadtex.errors import ProfileFormatError, UnitConflictWarning
from roadtex.profiles.conditioning import sampling_interval
from roadtex.profiles.units import UNITS, unit_factor

#: Fields (lower case, stripped) that mark a missing reading rather than a bad number.
DROPOUT_TOKENS = frozenset({"", "nan", "na", "n/a", "null", "-"})

#: Column names (lower case, unit stripped) taken as the distance or height column when none is given.
DISTANCE_NAMES = ("distance", "dist", "position", "pos", "x", "chainage", "station", "s",
                  "longitudinal_position", "location")
HEIGHT_NAMES = ("height", "z", "elevation", "profile", "texture", "h", "y", "relative_height")
#: A reader's answer: positions (m), heights (m), metadata, history lines, dx given or stored (m or None).
ReadResult = tuple[np.ndarray, np.ndarray, dict, list[str], object]


def refuse_binary(head: bytes, name: str) -> None:
    """Refuses a text file whose first bytes ``head`` hold NUL bytes without a UTF-16 byte-order
    mark (binary data, or UTF-16 without its mark), saying which: called on the head before the
    whole file is read (a 2 GB file of NULs took 5.9 s and 2.2 GB to be refused)."""
    if b"\x00" not in head or head.startswith((b"\xff\xfe", b"\xfe\xff")):
        return
    if head[1::2].count(0) > 0.4 * len(head[1::2]) and head[0::2].count(0) < 0.4 * len(head[0::2]):
        hint = "UTF-16 (little-endian) without a byte-order mark: pass encoding='utf-16-le'"
    elif head[0::2].count(0) > 0.4 * len(head[0::2]) and head[1::2].count(0) < 0.4 * len(head[1::2]):
        hint = "UTF-16 (big-endian) without a byte-order mark: pass encoding='utf-16-be'"
    else:
        hint = "binary data, not a text profile"
    raise ProfileFormatError(f"{name} looks like {hint}")


def decode_text(raw: bytes, encoding: str | None, name: str) -> tuple[bytes, str]:
    """Returns the content as UTF-8 bytes with '\\n' line ends, and the encoding used."""
    if not raw or raw.isspace():
        raise ProfileFormatError(f"{name} is empty")
    if encoding is not None:
        try:
            text = raw.decode(encoding)
        except (LookupError, UnicodeDecodeError) as exc:
            raise ProfileFormatError(f"{name} cannot be decoded as {encoding}: {exc}") from None
        data, used = text.encode("utf-8"), encoding
    elif raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            data, used = raw.decode("utf-16").encode("utf-8"), "utf-16"
        except UnicodeDecodeError as exc:
            raise ProfileFormatError(f"{name} has a UTF-16 byte-order mark but is not valid UTF-16: {exc}") from None
    elif raw.startswith(b"\xef\xbb\xbf"):
        data, used = raw[3:], "utf-8"
    else:
        refuse_binary(raw[:4096], name)
        try:
            if not raw.isascii():
                raw.decode("utf-8")
            data, used = raw, "utf-8"
        except UnicodeDecodeError:
            # Old instrument software writes Windows-1252/Latin-1 (a degree sign or umlaut in a header).
            data, used = raw.decode("latin-1").encode("utf-8"), "latin-1"
    # The CSV parser takes CRLF as it is; only old Mac files with bare CR need rewriting. Judging
    # by the head spares two passes over a large file (files do not mix line ends in practice).
    first_cr = data.find(b"\r")
    if first_cr >= 0:
        head = data[first_cr:first_cr + 65536]
        if head.count(b"\r") != head.count(b"\r\n"):
            data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    return data, used


def split_column_name(column: str) -> tuple[str, str | None]:
    """'Distance (mm)' -> ('distance', 'mm'); 'height_mm' -> ('height', 'mm'); 'z' -> ('z', None)."""
    text = column.strip()
    bracket = re.search(r"[\(\[]\s*([^\)\]]*?)\s*[\)\]]\s*$", text)
    if bracket:
        base = text[:bracket.start()].strip()
        unit: str | None = bracket.group(1)
    else:
        base, unit = text, None
        suffix = re.match(r"^(.*?)[_\s]+([A-Za-zµμ]+)$", text)
        if suffix and suffix.group(2).lower() in UNITS:
            base, unit = suffix.group(1), suffix.group(2)
    base = re.sub(r"[\s\-]+", "_", base.strip().lower()).rstrip(":")
    return base, unit


#: The most characters of a file's text an error message quotes (a message must not carry a file's
#: contents: a manifest row pointing at /etc/passwd copied its lines into errors.parquet and the log).
EXCERPT_CHARACTERS = 24


def excerpt(text: str, limit: int = EXCERPT_CHARACTERS) -> str:
    """A short, escaped quotation of a file's ``text`` for a message: its first ``limit`` characters
    as a Python literal (control characters escaped), '...' when there is more."""
    return repr(text[:limit]) + ("..." if len(text) > limit else "")


def quoted_fields(message: str) -> str:
    """A parser's message with the file's text it quotes (polars puts it in backticks) cut to an
    :func:`excerpt`, and the message itself to one short line."""
    return re.sub(r"`([^`]*)`", lambda match: excerpt(match.group(1), 12), message)[:200]


def column_list(names: list[str], most: int = 12) -> str:
    """The column names for a message: all of them, or the first few and how many there are (each
    an :func:`excerpt`: a "header" may be a line of any file)."""
    shown = "[" + ", ".join(excerpt(str(name)) for name in names[:most if len(names) <= most else most - 2]) + "]"
    return shown if len(names) <= most else f"{shown} ... ({len(names)} columns)"


def pick_column(names: list[str], wanted: str | int | None, synonyms: tuple[str, ...], what: str,
                 required: bool, *, where: str = "a read_profile option or manifest column") -> int | None:
    if isinstance(wanted, (int, np.integer)) and not isinstance(wanted, bool):
        if not -len(names) <= int(wanted) < len(names):
            raise ProfileFormatError(f"{what} column index {wanted} is out of range for {len(names)} columns")
        return int(wanted) % len(names)
    if isinstance(wanted, str):
        for i, name in enumerate(names):
            if name == wanted or name.strip().lower() == wanted.strip().lower() or split_column_name(name)[0] == wanted.lower():
                return i
        raise ProfileFormatError(f"unknown {what} column {wanted!r}; the columns are {column_list(names)}")
    if wanted is not None:
        raise ProfileFormatError(f"{what}_column must be a column name or index, got {wanted!r}")
    bases = [split_column_name(n)[0] for n in names]
    for synonym in synonyms:
        if synonym in bases:
            return bases.index(synonym)
    if required:
        hint = (", or give dx (m) for evenly spaced heights (a read_profile option, the manifest column dx or "
                "roadtex process --input-dx)") if what == "distance" else ""
        raise ProfileFormatError(f"no {what} column among {column_list(names)}; name it with {what}_column ({where})"
                                 f"{hint}")
    return None


#: Where a user gives a reader option: in Python, in the bulk job's manifest, on the command line.
WHERE_OPTIONS = "read_profile option, manifest column or roadtex process --{flag}"


def check_units_given(names: list[str], columns: dict[str, tuple[int | None, str | None]],
                      unclear: list[str] | tuple[str, ...] = ()) -> None:
    """Refuses, naming every one at once, the columns (``what -> (index, unit given)``) whose unit
    neither the header nor the options give: a number without its unit is never guessed. ``unclear``:
    the file's metadata lines that mention units but state none roadtex can take (quoted)."""
    missing = [(what, names[index]) for what, (index, given) in columns.items()
               if index is not None and given is None and split_column_name(names[index])[1] is None]
    if missing:
        columns_text = " and ".join(f"the {what} column {column!r}" for what, column in missing)
        options = " and ".join(f"{what}_unit" for what, _ in missing)
        flags = ", ".join(f"--{what}-unit" for what, _ in missing)
        said = (f"the file's line(s) {', '.join(excerpt(u, 40) for u in unclear[:3])} state no one unit per column"
                if unclear else "the file states none")
        raise ProfileFormatError(f"no unit for {columns_text} ({said}): give {options} ('m', 'mm', "
                                 f"'um', ...) as a read_profile option, a manifest column or roadtex process {flags}")


def column_unit(names: list[str], index: int, given: str | None, what: str, *, source: str = "file",
                default: str | None = None) -> float:
    """Factor to metres of a column: the unit its header states; else the unit given, else
    ``default``. A given unit that disagrees with the header's is ignored with a
    :class:`UnitConflictWarning` (``source`` names the file): a job-wide ``--height-unit`` is for
    files whose header states none, and must not rescale the others."""
    stated = split_column_name(names[index])[1]
    if stated is None:
        if given is None and default is None:
            raise ProfileFormatError(f"no unit for the {what} column {names[index]!r}: give {what}_unit ('m', 'mm', "
                                     f"'um', ...; {WHERE_OPTIONS.format(flag=what + '-unit')})")
        return unit_factor(given if given is not None else default, what)  # type: ignore[arg-type]
    factor = unit_factor(stated, f"the {what} column {names[index]!r}")
    if given is not None and unit_factor(given, what) != factor:
        warnings.warn(f"{source}: the {what} column {names[index]!r} states its unit, {stated}; the {what}_unit "
                      f"{given!r} given is ignored for it (a given unit applies where the header states none)",
                      UnitConflictWarning, stacklevel=5)   # the caller of read_profile
    return factor


def stated_unit(names: list[str], index: int | None, given: str | None, default: str | None = None) -> str | None:
    """Where the unit of column ``index`` comes from, when it is certain: the header's (which a
    given unit never overrides), else the one ``given`` for the file, else a ``default`` the format
    defines (a string naming it, e.g. "mm (the CAPTIF format)"); without a column (a bare dx),
    :func:`bare_interval_unit`."""
    if index is None:
        return bare_interval_unit(given)
    stated = split_column_name(names[index])[1]
    if stated is not None:
        return f"{stated} (the file's header)"
    if given is not None:
        return f"{given} (given for the file)"
    return default


def bare_interval_unit(given: str | None, source: str = "given for the file") -> str | None:
    """Where the unit of a heights-only file's interval comes from, when it is certain: a bare dx
    is in metres by definition (read_profile's and read_surface's ``dx``, the manifest column dx,
    ``--input-dx``, a sidecar's dx), so a distance unit ``given`` for the file (from ``source``) as
    metres states it ("m (given for the file)"); any other unit, or none, leaves it assumed (None):
    a dx of 0.01 with distance_unit mm is still 1 cm, and judged as an assumed one is."""
    if given is None or unit_factor(given, "the distances") != 1.0:
        return None
    return f"{given} ({source})"


def nominal_dx(positions: np.ndarray) -> float:
    """The file's sampling interval (m) from its sorted positions (m): the mean step, gaps (rows
    missing) counted as the steps they span (:func:`~roadtex.profiles.conditioning.sampling_interval`)."""
    return sampling_interval(positions)


def sorted_samples(positions: np.ndarray, heights: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray, str]:
    """Sorts by position; merges exact duplicates that agree; refuses duplicates that conflict."""
    note = ""
    if np.isnan(positions).any():
        raise ProfileFormatError(f"{name}: distance is NaN at data row {int(np.flatnonzero(np.isnan(positions))[0]) + 1}")
    steps = np.diff(positions)
    if np.any(steps <= 0):
        order = np.argsort(positions, kind="stable")
        moved = int(np.count_nonzero(order != np.arange(order.size)))
        positions, heights = positions[order], heights[order]
        if moved:
            note = f"; sorted {moved} samples by position"
        same = np.flatnonzero(np.diff(positions) == 0)
        if same.size:
            a, b = heights[same], heights[same + 1]
            conflict = ~((a == b) | np.isnan(a) | np.isnan(b))
            if conflict.any():
                i = int(same[np.flatnonzero(conflict)[0]])
                raise ProfileFormatError(f"{name}: {same.size} duplicate positions, e.g. {positions[i]:.9g} m with heights "
                                 f"{heights[i]:.9g} and {heights[i + 1]:.9g} m that disagree: cannot sort them out "
                                 f"{duplicate_cause(positions, same.size)}")
            keep = np.ones(positions.size, dtype=bool)
            keep[same + 1] = False
            # a duplicate pair keeps the valid height of the two
            heights = heights.copy()
            heights[same] = np.where(np.isnan(a), b, a)
            positions, heights = positions[keep], heights[keep]
            note += f"; merged {same.size} duplicate positions"
    return positions, heights, note


def duplicate_cause(positions: np.ndarray, duplicates: int) -> str:
    """The likely cause of ``duplicates`` positions (m, sorted) repeated with other heights, for
    the message: distances rounded more coarsely than the sampling (many repeats, distinct
    positions a whole step apart), else readings of a 3-D surface."""
    distinct = np.unique(positions)
    if duplicates >= 0.01 * positions.size and distinct.size > 1:
        written = float(np.median(np.diff(distinct)))
        readings = float((positions[-1] - positions[0]) / (positions.size - 1))
        if written > 1.5 * readings:
            return (f"(the distances look rounded to steps of {written:.3g} m, coarser than the {readings:.3g} m "
                    "between readings: export them with more decimals)")
    return "(a 3-D surface of x, y, z readings? give its manifest row the format 'surface')"


def parse_table(data: bytes, separator: str, n_columns: int, name: str,
                 first_line: int, *, decimal_comma: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Numeric table (rows, n_columns) from delimited UTF-8 text, and the mask of missing fields
    (empty or absent; they are NaN in the table, like the written ``NaN`` drop-outs)."""
    schema = {f"c{i}": pl.Float64 for i in range(n_columns)}
    try:
        frame = pl.read_csv(io.BytesIO(data), has_header=False, separator=separator, schema=schema,
                            null_values=["", "NA", "N/A", "null", "-"], comment_prefix=None, quote_char='"',
                            decimal_comma=decimal_comma)
    except (Exception, pl.exceptions.PanicException) as exc:
        # polars raises ComputeError/NoDataError with a long hint (keep its first line), and on some
        # malformed input (a file cut inside a quoted field) panics: a PanicException, which is a
        # BaseException, so it is named here to be reported as what it is, a bad file.
        message = quoted_fields(str(exc).strip().splitlines()[0]) if str(exc).strip() else type(exc).__name__
        where = first_bad_line(data, separator, decimal_comma, n_columns)
        if where is not None:
            index, line = where
            message = f"line {first_line + index + 1} is not a row of {n_columns} numbers: {excerpt(line)}"
        raise ProfileFormatError(f"{name}: cannot read the numbers after line {first_line}: {message}") from None
    missing = np.column_stack([frame.get_column(c).is_null().to_numpy() for c in frame.columns]) \
        if frame.height else np.zeros((0, n_columns), dtype=bool)
    table = frame.to_numpy().astype(np.float64, copy=False).reshape(frame.height, n_columns)
    return table, missing


def first_bad_line(data: bytes, separator: str, decimal_comma: bool,
                   n_columns: int | None = None) -> tuple[int, str] | None:
    """The first line (0-based, and its text) of a table that holds a field that is not a number
    or a drop-out, or more than ``n_columns`` fields: where a parse failed, for the message (slow;
    only on the failure path)."""
    for index, raw in enumerate(data.split(b"\n")):
        line = raw.decode("utf-8", "replace").rstrip("\r")
        fields = line.split(separator)
        if n_columns is not None and len(fields) > n_columns and '"' not in line:
            return index, line
        for field in fields:
            text = field.strip().strip('"')
            if text.lower() in DROPOUT_TOKENS:
                continue
            try:
                float(text.replace(",", ".") if decimal_comma else text)
            except ValueError:
                return index, line
    return None


def first_lines(data: bytes, count: int) -> tuple[list[bytes], list[int]]:
    """The first ``count`` lines and the byte offset where each ends (after its newline)."""
    lines, ends, start = [], [], 0
    while len(lines) < count and start < len(data):
        stop = data.find(b"\n", start)
        stop = len(data) if stop < 0 else stop + 1
        lines.append(data[start:stop].rstrip(b"\r\n"))
        ends.append(stop)
        start = stop
    return lines, ends


def parse_value(text: str) -> object:
    text = text.strip()
    for cast in (int, float):
        try:
            value = cast(text)
            if isinstance(value, float) and not math.isfinite(value):
                return text
            return value
        except ValueError:
            pass
    return text
