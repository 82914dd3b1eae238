"""A manifest as editors and spreadsheets save it: its text decoded (UTF-8, else Windows-1252, Excel's
"CSV (Comma delimited)"), its header's names matched to the known columns ("Run ID" is ``run_id``),
and what a spreadsheet adds without a word (empty rows, empty unnamed trailing columns) set aside
with a note, never silently."""

from __future__ import annotations

import io
import re
from pathlib import Path
from typing import Sequence

import polars as pl

from roadtex.archive.schemas import MANIFEST_COLUMNS, NOISE_PREFIX, READER_COLUMNS
from roadtex.errors import ManifestError
from roadtex.profiles.readers.text import excerpt


def decoded(raw: bytes, path: Path, notes: list[str]) -> bytes:
    """``raw`` (no byte-order mark) as UTF-8 bytes: as it is when it is UTF-8, else decoded as
    Windows-1252 (Excel's "CSV (Comma delimited)" on Windows; Latin-1's printable characters are
    the same), with a note naming the first line that is not UTF-8; refused when it is neither."""
    try:
        raw.decode("utf-8")
        return raw
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        byte = f"byte 0x{raw[exc.start]:02x}"
    try:
        text = raw.decode("cp1252")
    except UnicodeDecodeError:
        raise ManifestError(f"manifest {path}, line {line}: not UTF-8 text ({byte}), nor Windows-1252: save it as "
                            "CSV UTF-8 (Excel: File > Save As > 'CSV UTF-8 (Comma delimited)')") from None
    notes.append(f"not UTF-8 (line {line}: {byte}); read as Windows-1252 (cp1252, what Excel's 'CSV (Comma "
                 "delimited)' writes): check its paths' accented letters, or save it as CSV UTF-8")
    return text.encode("utf-8")


def read_text_manifest(path: Path, notes: list[str] | None = None) -> pl.DataFrame:
    """A CSV or TSV manifest as strings, as spreadsheets save it: comma, tab or (European Excel)
    semicolon separated, Excel's ``sep=;`` line, a byte-order mark, UTF-8 or Windows-1252 text
    (:func:`decoded`). Columns without a name in the header that hold nothing (Excel's trailing
    ``;;``) are left out; one holding a value, or a name given twice, is refused. With
    semicolons, a decimal comma in the numeric columns (``speed_kmh``, ``dx``, ``noise_1000``:
    ``0,5``) is a decimal point: every number is then read as written. What is left out or
    decoded otherwise is said in ``notes``."""
    notes = notes if notes is not None else []
    raw = path.read_bytes()
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):   # UTF-16 with its byte-order mark (Excel's "Unicode text")
        try:
            raw = raw.decode("utf-16").encode("utf-8")
        except UnicodeDecodeError as exc:
            raise ManifestError(f"manifest {path}: starts as UTF-16 but does not decode as such ({exc.reason} at byte "
                                f"{exc.start}); save it as UTF-8 CSV") from None
    elif b"\x00" in raw[:4096]:
        raise ManifestError(f"manifest {path}: contains NUL bytes, so it is not UTF-8 text (UTF-16 without a "
                            "byte-order mark, or not a text file); save it as UTF-8 CSV")
    raw = decoded(raw.removeprefix(b"\xef\xbb\xbf"), path, notes)
    lines = raw.split(b"\n", 2)
    first = lines[0].strip()
    hint = first.lower().startswith(b"sep=") and len(first) == 5
    if hint:
        raw = raw[len(lines[0]) + 1:]
        header = lines[1] if len(lines) > 1 else b""
    else:
        header = lines[0]
    if hint:
        separator = first[4:5].decode("latin-1")
    elif path.suffix.lower() in (".tsv", ".tab") or (b"\t" in header and b"," not in header):
        separator = "\t"
    elif b";" in header and b"," not in header:
        separator = ";"
    else:
        separator = ","
    # the header read as a row: polars would name an empty header cell '' and a repeated one
    # '_duplicated_0', names no file has
    cells = pl.read_csv(io.BytesIO(raw), separator=separator, infer_schema=False, has_header=False)
    names = [(name or "").strip() for name in cells.row(0)]
    body = cells.slice(1)
    keep: list[str] = []
    unnamed = 0
    for index, (column, name) in enumerate(zip(body.columns, names)):
        if not name:
            values = body[column].drop_nulls().str.strip_chars()
            held = values.filter(values != "")
            if held.len():
                raise ManifestError(f"manifest {path}: column {index + 1} has no name in the header but holds "
                                    f"{excerpt(held[0])} (and {held.len() - 1} other value(s)): name it, or delete it")
            unnamed += 1
            continue
        if name in names[:index]:
            raise ManifestError(f"manifest {path}: the header names column {excerpt(name)} twice (columns "
                                f"{names.index(name) + 1} and {index + 1}): keep one")
        keep.append(column)
    if unnamed:
        notes.append(f"{unnamed} empty column(s) without a name left out (a spreadsheet's trailing separators)")
    table = body.select(keep)
    table.columns = [name for name in names if name]
    if separator == ";":
        table = canonical_columns(table, f"manifest {path}")
        numeric = [c for c in table.columns
                   if c in ("speed_kmh", "dx", "dy", "start", "dropout_value") or c.startswith(NOISE_PREFIX)]
        table = table.with_columns(pl.col(c).str.replace(",", ".", literal=True) for c in numeric)
    return table


def column_key(name: str) -> str:
    """A header name as :func:`canonical_columns` matches it: lower case, blanks, hyphens and
    underscores one underscore (``"Run ID"``, ``"run-id"`` and ``"RUN_ID"`` are ``run_id``)."""
    return re.sub(r"[\s_\-]+", "_", name.strip().lower()).strip("_")


def canonical_columns(table: pl.DataFrame, where: str, extra_columns: Sequence[str] = ()) -> pl.DataFrame:
    """``table`` with each column whose name is a known column's (or one of ``extra_columns``) but
    for case, blanks and underscores (:func:`column_key`: ``Path``, ``Run ID``, ``Noise 1000``)
    renamed to it; two columns that would then share a name are refused, naming both."""
    names = [*MANIFEST_COLUMNS, *READER_COLUMNS, *extra_columns]
    by_key = {column_key(name): name for name in names}
    renames: dict[str, str] = {}
    for column in table.columns:
        if column in names or column.startswith(NOISE_PREFIX):
            continue
        key = column_key(column)
        target = by_key.get(key) or (key if key.startswith(NOISE_PREFIX) else None)
        if target is not None:
            renames[column] = target
    targets: dict[str, str] = {}
    for column in table.columns:
        target = renames.get(column, column)
        if target in targets:
            raise ManifestError(f"{where}: columns {excerpt(targets[target])} and {excerpt(column)} both name "
                                f"{target!r} (header names are matched ignoring case, blanks and underscores): keep one")
        targets[target] = column
    return table.rename(renames) if renames else table


def blank_rows(table: pl.DataFrame) -> pl.Series:
    """Which rows of ``table`` are wholly empty: every cell null, or blank text (a blank line at the
    end of a file, a spreadsheet's cleared row saved as ``;;``)."""
    if not table.width:
        return pl.Series([False] * table.height, dtype=pl.Boolean)
    empty = [pl.col(name).is_null() | (pl.col(name).str.strip_chars() == "") if dtype == pl.String
             else pl.col(name).is_null() for name, dtype in table.schema.items()]
    return table.select(pl.all_horizontal(empty).fill_null(True)).to_series()
