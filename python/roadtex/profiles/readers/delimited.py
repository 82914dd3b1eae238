"""Delimited text (CSV, TSV, semicolon or blank separated) with a distance and a height column."""

from __future__ import annotations

import re

import numpy as np

from roadtex.errors import ProfileFormatError
from roadtex.profiles.plausibility import set_distance_unit
from roadtex.profiles.readers.grid import grid_positions
from roadtex.profiles.readers.npy import stored_record
from roadtex.profiles.readers.screening import (
    THOUSANDS,
    check_headerless_fields,
    dropout_codes,
    metadata_units,
    with_metadata_units,
)
from roadtex.profiles.readers.text import (
    DISTANCE_NAMES,
    DROPOUT_TOKENS,
    HEIGHT_NAMES,
    ReadResult,
    check_units_given,
    column_unit,
    excerpt,
    first_lines,
    parse_table,
    parse_value,
    pick_column,
    split_column_name,
    stated_unit,
)
from roadtex.profiles.units import UNITS

#: The comment line tag under which :func:`roadtex.write_profile` stores metadata and history.
ROADTEX_TAG = "roadtex-profile"
#: More columns than this without a header (and no height column given) is a grid of heights,
#: not a profile: its first two columns are not a distance and a height.
MAX_HEADERLESS_COLUMNS = 8


def sniff_separator(lines: list[bytes]) -> str:
    sample = [line for line in lines if line.strip()][:5]
    for separator in ("\t", ";", ","):
        counts = {line.count(separator.encode()) for line in sample}
        if len(counts) == 1 and counts.pop() > 0:
            return separator
    for separator in ("\t", ";", ","):
        if all(separator.encode() in line for line in sample[1:]) and sample[1:]:
            return separator
    return " "


def sniff_decimal(lines: list[bytes], separator: str) -> str:
    """',' when every field of the sample rows that holds a comma reads as a number with a decimal
    comma (a European spreadsheet export: ``12,5;-3,015``), else '.'."""
    if separator == ",":
        return "."
    fields = [f.strip() for line in lines for f in line.decode("utf-8", "replace").split(separator) if f.strip()]
    with_comma = [f for f in fields if "," in f]
    if with_comma and all(re.fullmatch(r"[-+]?\d*,\d+([eE][-+]?\d+)?", f) for f in with_comma):
        return ","
    return "."


def is_number(text: str, decimal: str = ".") -> bool:
    try:
        float(text.replace(",", ".") if decimal == "," else text)
        return True
    except ValueError:
        return text.strip().lower() in DROPOUT_TOKENS


def is_number_row(line: bytes) -> bool:
    """A line whose fields are all numbers (or drop-outs) under some delimiter: a data row."""
    text = line.decode("utf-8", "replace").strip()
    if not text:
        return False
    for separator in ("\t", ";", ","):
        if separator in text:
            fields = [f.strip().strip('"') for f in text.split(separator)]
            decimal = "," if separator != "," else "."
            if all(is_number(f, decimal) or is_number(f) for f in fields) and any(f.strip() for f in fields):
                return True
    return all(is_number(f) or is_number(f, ",") for f in text.split())


def preamble_length(rest: list[bytes]) -> int:
    """How many lines of ``rest`` come before the table's header line: a block of metadata lines
    (``Site: A1``, ``Operator;J. Smith``, Excel's ``sep=;``) that instruments and spreadsheets
    write without a comment mark. 0 when the table starts at once (a header line, or data, first):
    the table's first data row is the first of three number rows in a row."""
    rows = [i for i, line in enumerate(rest) if line.strip()]
    for k in range(len(rows) - 2):
        if all(is_number_row(rest[i]) for i in rows[k:k + 3]):
            # the header is the last non-blank line before the data; the preamble is what precedes it
            return rows[k - 1] if k >= 2 else 0
    return 0


def is_units_row(line: bytes) -> bool:
    """A header line of units only (``mm;mm``, ``[m]\t[mm]``): the second of two header rows."""
    fields = [f.strip().strip('"').strip("()[] ") for f in re.split(r"[\t;,]", line.decode("utf-8", "replace"))]
    return any(fields) and all(f.lower() in UNITS or f in ("", "-") for f in fields)


def preamble_metadata(lines: list[bytes]) -> tuple[dict[str, object], str | None]:
    """The ``key: value`` (or ``=``, ``;``, tab) pairs of a metadata block, and Excel's ``sep=X`` delimiter."""
    metadata: dict[str, object] = {}
    separator = None
    for line in lines:
        text = line.decode("utf-8", "replace").strip()
        hint = re.fullmatch(r"sep=(.)", text)
        if hint:
            separator = hint.group(1)
            continue
        parts = re.split(r"\s*[:=;\t]\s*", text, maxsplit=1)
        if len(parts) == 2 and parts[0].strip() and parts[1].strip().strip(";,\t"):
            key = re.sub(r"\W+", "_", parts[0].strip().lower()).strip("_")
            if key:
                metadata[key] = parse_value(parts[1].strip().strip(";,\t").strip('"'))
    return metadata, separator


#: Metadata keys (lower case) that name a sampling interval: a heights-only file's header may state it.
SPACING_KEY = re.compile(r"(^|_)(dx|spacing|interval|sampling|step|resolution)(_|$)")


def spacing_in_header(metadata: dict[str, object]) -> str:
    """For the message refusing heights without dx: the sampling interval the file's header states,
    if any, quoted as written (its unit is the header's; roadtex does not guess it into dx)."""
    said = [f"{key}: {value}" for key, value in metadata.items() if SPACING_KEY.search(key)]
    if not said:
        return ""
    return f"; the file's header says {'; '.join(repr(s) for s in said[:3])}: give that interval as dx, in metres"


def two_columns_by_position(names: list[str], options: dict) -> bool:
    """Whether a two-column table's header names neither a known height nor a known distance column
    (and no column is named in the options), while both units are certain (given, or stated in the
    header: ``Abstand (mm);Hoehe (mm)``): its columns are then taken by position, distance first, as
    in a file without a header. A table the other way round does not pass as one: its first column
    would have to be evenly spaced positions."""
    if len(names) != 2 or options.get("height_column") is not None or options.get("distance_column") is not None:
        return False
    if options.get("dx") is not None:
        return False
    units = (options.get("distance_unit"), options.get("height_unit"))
    if any(given is None and split_column_name(name)[1] is None for given, name in zip(units, names)):
        return False
    for kind, known in (("height", HEIGHT_NAMES), ("distance", DISTANCE_NAMES)):
        try:
            if pick_column(names, None, known, kind, False) is not None:
                return False
        except ProfileFormatError:   # ambiguous names: not a case for positions
            return False
    return True


def read_delimited(data: bytes, name: str, options: dict) -> ReadResult:
    lines, ends = first_lines(data, 200)
    metadata: dict[str, object] = {}
    history: list[str] = []
    skip = 0
    blank_before = 0   # the blank lines right before the table: leading drop-outs of heights without a header
    for line in lines:
        text = line.decode("utf-8", "replace").strip()
        if not text:
            skip += 1
            blank_before += 1
            continue
        if not text.startswith("#"):
            break
        skip += 1
        blank_before = 0
        body = text.lstrip("#").strip()
        if body.startswith(ROADTEX_TAG + ":"):
            stored = stored_record(body[len(ROADTEX_TAG) + 1:], lambda why: ProfileFormatError(
                f"{name}: damaged {ROADTEX_TAG} header line: {why}"))
            metadata.update(stored.get("metadata", {}))
            history.extend(stored.get("history", []))
            if stored.get("dx") is not None and options.get("dx") is None:
                options = {**options, "dx": stored["dx"]}
        elif re.match(r"^[^:=]+[:=]", body):
            key, value = re.split(r"[:=]", body, maxsplit=1)
            metadata[re.sub(r"\W+", "_", key.strip().lower()).strip("_")] = parse_value(value)
    rest = lines[skip:]
    if not rest:
        raise ProfileFormatError(f"{name}: no data (only comments or blank lines)")
    preamble = preamble_length(rest)
    names_line = None
    if preamble and is_units_row(rest[preamble]):
        # two header rows, names then units ("Distance;Height" / "mm;mm"): the names are the
        # last line before the units
        names_at = max(i for i in range(preamble) if rest[i].strip())
        names_line, preamble = rest[names_at], names_at
    if preamble:
        found, hint = preamble_metadata(rest[:preamble])
        for key, value in found.items():
            metadata.setdefault(key, value)
        if hint is not None and not options.get("delimiter"):
            options = {**options, "delimiter": hint}
        history.append(f"{preamble} line(s) before the table's header read as metadata "
                       f"({', '.join(found) or 'none recognised'})")
    if names_line is not None:
        preamble += 1       # the names line too: the units line stands as the header below
    skip += preamble
    rest = rest[preamble:]
    separator = options.get("delimiter") or sniff_separator(rest[:5])
    offset = ends[skip - 1] if skip else 0
    body = data[offset:]
    header_text = rest[0].decode("utf-8", "replace")
    if separator == " ":
        body = re.sub(rb"[ \t]+", b"\t", re.sub(rb"(?m)^[ \t]+|[ \t]+$", b"", body))
        separator = "\t"
        rest = [re.sub(rb"[ \t]+", b"\t", line.strip()) for line in rest]
        # blank-separated headers may hold names with single blanks ("height (mm)"): prefer runs
        # of two or more blanks as separators when that matches the data's column count
        columns = len(rest[1].split(b"\t")) if len(rest) > 1 else len(rest[0].split(b"\t"))
        wide = [f for f in re.split(r"\s{2,}|\t", header_text.strip()) if f]
        if len(wide) == columns:
            rest[0] = "\t".join(wide).encode()
    decimal = options.get("decimal") or sniff_decimal(rest[1:6] or rest[:1], separator)
    if decimal not in (".", ","):
        raise ProfileFormatError(f"{name}: decimal must be '.' or ',', got {decimal!r}")
    if decimal == "," and separator == ",":
        raise ProfileFormatError(f"{name}: a comma cannot be both the delimiter and the decimal mark; give the "
                                 "delimiter (a read_profile option, manifest column or roadtex process --delimiter)")
    first = [f.strip().strip('"') for f in rest[0].decode("utf-8", "replace").split(separator)]
    if names_line is not None:
        units = first
        first = [f.strip().strip('"') for f in names_line.decode("utf-8", "replace").split(separator)]
        if len(first) != len(units):
            raise ProfileFormatError(f"{name}: the header's names {first} and units {units} differ in number")
        first = [f"{n} ({u.strip('()[] ')})" if u.strip("()[] ") else n for n, u in zip(first, units)]
    has_header = not all(is_number(f, decimal) for f in first)
    if has_header and len(rest) > 1:
        data_columns = len(rest[1].decode("utf-8", "replace").split(separator))
        if data_columns != len(first):
            raise ProfileFormatError(f"{name}: the header names {len(first)} columns ({first}) but the first data row "
                             f"has {data_columns} fields")
    if has_header:
        names = first
        body = body[body.find(b"\n") + 1:] if b"\n" in body else b""
        if not body or body.isspace():
            raise ProfileFormatError(f"{name}: a header line ({excerpt(separator.join(names))}) but no data rows")
    else:
        names = [f"column_{i + 1}" for i in range(len(first))]
        if len(names) > MAX_HEADERLESS_COLUMNS and options.get("height_column") is None:
            raise ProfileFormatError(
                f"{name}: {len(names)} columns of numbers and no header: a grid of heights (a 3-D surface, one line "
                "per row across the road), not a profile? A profile file has a distance and a height column (name "
                "them with distance_column, height_column); read a surface as a 2-D .npy (numpy.save the grid, give "
                "dx and dy) with format 'surface'")
    n_columns = len(names)
    first_data_line = skip + (2 if has_header else 1)
    if decimal == ",":
        refuse_thousands(rest[1:6] if has_header else rest[:5], separator, name)
    if not has_header:
        check_headerless_fields(body, separator, n_columns, name, first_data_line, options)
    if not data.endswith(b"\n"):
        last = body.rstrip(b"\r\n").rsplit(b"\n", 1)[-1]
        if last.count(separator.encode()) < n_columns - 1 or not last.split(separator.encode())[-1].strip():
            raise ProfileFormatError(f"{name}: the last line {excerpt(last.decode('utf-8', 'replace'))} has fewer than "
                             f"{n_columns} fields and no line end: the file looks truncated")
    table, absent = parse_table(body, separator, n_columns, name, first_data_line - 1, decimal_comma=decimal == ",")
    # Blank lines (or lines of bare delimiters, ";;") at the end, as spreadsheets leave them, are no rows.
    blank = absent.all(axis=1)
    last = table.shape[0] - int(np.argmin(blank[::-1])) if not blank.all() else 0
    trailing = table.shape[0] - last
    table, absent, blank = table[:last], absent[:last], blank[:last]
    if table.shape[0] == 0:
        raise ProfileFormatError(f"{name}: no data rows")
    # The data row each table row came from (blank lines inside a table with a distance column
    # are dropped below; in a heights-only table an empty line is a drop-out on the grid).
    row_numbers = np.arange(table.shape[0])
    if has_header and two_columns_by_position(names, options):
        # a hand-made export with headers in another language (Abstand;Hoehe) and both units certain:
        # two columns can only be distance then height, as in a header-less file
        d_index, h_index = 0, 1
        first_column = table[~absent[:, 0], 0]
        if first_column.size > 1 and not np.all(np.diff(first_column) > 0):
            raise ProfileFormatError(
                f"{name}: the header {names} names no known distance or height column, and its first column does "
                "not increase row by row, so it is no column of positions: name the columns with distance_column and "
                "height_column (read_profile options or manifest columns)")
        history.append(f"header {names} names no known distance or height column; with two columns and both units "
                       f"certain, the first ({names[0]!r}) is read as the distance and the second ({names[1]!r}) as "
                       "the height")
    elif has_header:
        h_index = pick_column(names, options.get("height_column"), HEIGHT_NAMES, "height", True)
        try:
            d_index = pick_column(names, options.get("distance_column"), DISTANCE_NAMES, "distance",
                                   options.get("dx") is None)
        except ProfileFormatError as exc:
            raise ProfileFormatError(f"{exc}{spacing_in_header(metadata)}") from None
    else:
        h_given, d_given = options.get("height_column"), options.get("distance_column")
        if n_columns == 1:
            h_index, d_index = pick_column(names, 0 if h_given is None else h_given, (), "height", True), None
        else:
            h_index = pick_column(names, 1 if h_given is None else h_given, (), "height", True)
            d_index = pick_column(names, 0 if d_given is None else d_given, (), "distance", False)
    assert h_index is not None
    if d_index is not None and blank.any():
        history.append(f"skipped {int(blank.sum())} blank line(s) inside the table")
        table, absent, row_numbers = table[~blank], absent[~blank], row_numbers[~blank]
    if d_index is None:
        table = heights_only_ends(table, history, blank_before if not has_header and not preamble else 0, trailing)
    stated, unclear = metadata_units(metadata)
    header_names = names
    names, notes = with_metadata_units(names, {"height": h_index, "distance": d_index}, stated, split_column_name)
    history.extend(notes)
    check_units_given(names, {"height": (h_index, options.get("height_unit")),
                              "distance": (d_index, options.get("distance_unit"))}, unclear)
    raw_heights, codes_note = dropout_codes(table[:, h_index], options.get("dropout_value"))  # type: ignore[arg-type]
    if codes_note:
        history.append(codes_note)
    heights = raw_heights * column_unit(names, h_index, options.get("height_unit"), "height", source=name)
    if d_index is not None:
        if absent[:, d_index].any():
            row = int(row_numbers[np.flatnonzero(absent[:, d_index])[0]])
            raise ProfileFormatError(f"{name}: data row {row + 1} (line {first_data_line + row}) has no distance")
        positions = table[:, d_index] * column_unit(names, d_index, options.get("distance_unit"), "distance", source=name)
    else:
        positions = grid_positions(heights.size, options, name)
    metadata.setdefault("format", "csv")
    set_distance_unit(metadata, stated_unit(names, d_index, options.get("distance_unit")))
    if d_index is not None and names[d_index] != header_names[d_index]:   # the unit a metadata line states
        set_distance_unit(metadata, f"{stated['distance'][0]} (the file's line {stated['distance'][1]!r})")
    return positions, heights, metadata, history, options.get("dx")


def heights_only_ends(table: np.ndarray, history: list[str], leading: int, trailing: int) -> np.ndarray:
    """A heights-only ``table`` with its ``leading`` empty lines (before the first height of a file
    without a header) added as drop-outs, so that no position shifts, and a history line for them
    and for the ``trailing`` empty lines after the last height, which end the run (trimmed)."""
    if leading:
        table = np.vstack([np.full((leading, table.shape[1]), np.nan), table])
        history.append(f"{leading} empty line(s) before the first height read as drop-outs (positions from start)")
    if trailing:
        history.append(f"{trailing} empty line(s) after the last height trimmed: the run ends at its last height")
    return table


def refuse_thousands(rows: list[bytes], separator: str, name: str) -> None:
    """Refuses a decimal-comma file whose sample ``rows`` write a number with a thousands separator
    (``1.000;2,383``): read with decimal commas, 1.000 is not 1000."""
    for line in rows:
        for field in line.decode("utf-8", "replace").split(separator):
            if THOUSANDS.fullmatch(field.strip().strip('"')):
                raise ProfileFormatError(
                    f"{name}: {excerpt(field.strip())} in a file with decimal commas: a thousands separator (1.000 for "
                    "1000)? roadtex does not read those: save the numbers without thousands separators")
