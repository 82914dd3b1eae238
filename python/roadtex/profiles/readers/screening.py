"""Checks of a text table's rows and readings before they become a profile: rows whose field count
differs, drop-out codes written as numbers (``-9999``), units stated in metadata lines, and a
second run whose distances restart. Each error is a ProfileFormatError naming the file."""

from __future__ import annotations

import re

import numpy as np

from roadtex.errors import ProfileFormatError
from roadtex.profiles.conditioning import format_number
from roadtex.profiles.readers.text import excerpt
from roadtex.profiles.units import UNITS

#: Numbers instruments and exports write for a missing reading, in the file's height unit. A
#: reading exactly equal to one is a drop-out when it cannot be texture (:func:`dropout_codes`).
DROPOUT_CODES = (-9999.0, -999.0, 9999.0, -99999.0)
#: A code is one when it is repeated at least this many times, ...
CODE_COUNT = 3
#: ... in stretches of at least this many consecutive readings (an isolated code is an outlier or
#: a spike, which conditioning counts and removes as such), ...
CODE_RUN = 2
#: ... and this many times more often than any of the :data:`CODE_NEIGHBOURS` other values nearest
#: to it: a texture reading that happens to equal a code is about as frequent as its neighbours.
CODE_EXCESS = 5.0
CODE_NEIGHBOURS = 10


def longest_run(mask: np.ndarray) -> int:
    """The length of the longest run of True in ``mask`` (0 when none)."""
    if not mask.any():
        return 0
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return int(np.max(np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)))


def dropout_codes(heights: np.ndarray, given: float | None) -> tuple[np.ndarray, str]:
    """``heights`` (in the file's height unit) with the readings that are a drop-out code set to
    NaN, and the history note saying so ("" when none).

    ``given`` (the ``dropout_value`` option, in the file's height unit) is the file's code, taken
    as stated. Without it, the readings exactly equal to one of :data:`DROPOUT_CODES` are drop-outs
    when the code cannot be texture: repeated (:data:`CODE_COUNT`), in stretches (:data:`CODE_RUN`)
    and far more often than the values nearest to it (:data:`CODE_EXCESS`)."""
    notes = []
    if given is not None:
        hits = heights == given
        if hits.any():
            heights = np.where(hits, np.nan, heights)
        notes.append(f"{int(hits.sum())} readings equal to the dropout_value {format_number(given)} read as drop-outs")
    for code in DROPOUT_CODES:
        hits = heights == code
        count = int(hits.sum())
        if count < CODE_COUNT or longest_run(hits) < CODE_RUN:
            continue
        values, counts = np.unique(heights[~hits & np.isfinite(heights)], return_counts=True)
        nearest = counts[np.argsort(np.abs(values - code), kind="stable")[:CODE_NEIGHBOURS]]
        if nearest.size and count <= CODE_EXCESS * int(nearest.max()):
            continue
        heights = np.where(hits, np.nan, heights)
        notes.append(f"{count} readings of {format_number(code)} (in the file's height unit) read as drop-outs: a "
                     "drop-out code, repeated in stretches far more often than any value near it (give dropout_value "
                     "to state a file's code)")
    return heights, "; ".join(notes)


def line_fields(body: bytes, separator: str) -> tuple[np.ndarray, np.ndarray]:
    """Per line of ``body`` (a table's rows, UTF-8 with '\\n' line ends): the number of fields
    (separators + 1) and whether the line is empty (nothing, or only a '\\r')."""
    raw = np.frombuffer(body, dtype=np.uint8)
    if raw.size == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool)
    ends = np.flatnonzero(raw == ord("\n"))
    if ends.size == 0 or ends[-1] != raw.size - 1:
        ends = np.append(ends, raw.size)
    starts = np.concatenate(([0], ends[:-1] + 1))
    separators = np.flatnonzero(raw == ord(separator))
    fields = np.diff(np.searchsorted(separators, np.concatenate(([0], ends)))) + 1
    length = ends - starts
    empty = (length == 0) | ((length == 1) & (raw[np.minimum(starts, raw.size - 1)] == ord("\r")))
    return fields, empty


def check_headerless_fields(body: bytes, separator: str, n_columns: int, name: str, first_line: int,
                            options: dict) -> None:
    """Refuses a table without a header whose rows have different numbers of fields, or whose
    first row has numeric columns beyond the distance and height that no option names: where a
    comma is both the delimiter and the decimal mark (``0,2,383`` for 0 and 2.383), taking the
    first two would read 2.383 as 2. ``first_line`` is the file line of the table's first row."""
    hint = (" (a comma delimiter with decimal commas, 0,2,383 for 0 and 2.383? Such a file cannot be read: save it "
            "with ';' or tab between the columns)") if separator == "," else ""
    if b'"' not in body:
        fields, empty = line_fields(body, separator)
        lines = body.split(b"\n")
        odd = np.flatnonzero((fields != n_columns) & ~empty)
        odd = [int(i) for i in odd[:50] if lines[int(i)].strip()]
        if odd:
            i = odd[0]
            raise ProfileFormatError(
                f"{name}: line {first_line + i} ({excerpt(lines[i].decode('utf-8', 'replace').rstrip())}) has "
                f"{int(fields[i])} fields where the first row has {n_columns}: a table without a header must have the "
                f"same number of fields on every row{hint}")
    if n_columns > 2 and options.get("height_column") is None:
        first = body.split(b"\n", 1)[0].decode("utf-8", "replace").rstrip()
        raise ProfileFormatError(
            f"{name}: line {first_line} ({excerpt(first)}) has {n_columns} numbers and the file no header: which are "
            "the distance and the height? Name them with distance_column and height_column (indexes from 0; a "
            f"read_profile option or manifest column){hint}")


#: Metadata keys (``# distance_unit: mm``, ``Units: mm``) that state the unit of the distance
#: column, the height column or both.
UNIT_KEYS = {"distance_unit": ("distance",), "distance_units": ("distance",), "x_unit": ("distance",),
             "position_unit": ("distance",), "height_unit": ("height",), "height_units": ("height",),
             "z_unit": ("height",), "unit": ("distance", "height"), "units": ("distance", "height")}


def metadata_units(metadata: dict[str, object]) -> tuple[dict[str, tuple[str, str]], list[str]]:
    """The units the file's metadata lines state: ``{"distance"|"height": (unit, the line as
    read)}``, and the lines that mention units in a way that is not one unit (quoted for the
    refusal of a missing unit: ``units: mm/um``)."""
    found: dict[str, tuple[str, str]] = {}
    unclear = []
    for key, value in metadata.items():
        if "unit" not in key:
            continue
        said = f"{key}: {value}"
        text = str(value).strip().strip("()[]").strip()
        if key in UNIT_KEYS and text.lower() in UNITS:
            for what in UNIT_KEYS[key]:
                found.setdefault(what, (text, said))
        else:
            unclear.append(said)
    return found, unclear


def with_metadata_units(names: list[str], columns: dict[str, int | None], stated: dict[str, tuple[str, str]],
                        split) -> tuple[list[str], list[str]]:
    """The column ``names`` with a unit the metadata states added to each column (``what -> index``)
    whose header states none (``split`` is the header-name parser), and the history lines saying so."""
    names = list(names)
    notes = []
    for what, index in columns.items():
        if index is None or what not in stated or split(names[index])[1] is not None:
            continue
        unit, said = stated[what]
        names[index] = f"{names[index]} ({unit})"
        notes.append(f"the {what} column {names[index]!r}: unit {unit} from the file's line {said!r}")
    return names, notes


#: A step back by more than this share of a file's span of distances is a restart ...
RESTART_SHARE = 0.1
#: ... when it is also more than this many of its readings' intervals (small files, local disorder).
RESTART_STEPS = 20


def restarts(positions: np.ndarray) -> np.ndarray:
    """The indexes ``i`` (of readings in file order, m) where the distances go back from reading
    ``i`` to ``i + 1`` by a large share of the run: a second run appended, its distances restarting.
    Empty when the distances only go one way (forwards, or a file written wholly in reverse), are
    locally out of order (readings swapped, sorted by the reader), or disordered all over (more
    such steps than one in a hundred readings: no runs appended, rows to sort)."""
    steps = np.diff(positions)
    if steps.size < 2 or not np.isfinite(steps).all():
        return np.zeros(0, dtype=np.int64)
    forward = steps if np.count_nonzero(steps > 0) >= np.count_nonzero(steps < 0) else -steps
    ahead = forward[forward > 0]
    if ahead.size == 0:
        return np.zeros(0, dtype=np.int64)
    span = float(np.max(positions) - np.min(positions))
    back = np.flatnonzero(-forward > max(RESTART_SHARE * span, RESTART_STEPS * float(np.median(ahead))))
    return back if back.size <= max(1, positions.size // 100) else np.zeros(0, dtype=np.int64)


def refuse_restarts(positions: np.ndarray, name: str) -> None:
    """Refuses a file whose distances restart (:func:`restarts`): sorting would interleave its two
    runs into one at half the interval."""
    back = restarts(positions)
    if back.size:
        i = int(back[0])
        more = f"; {back.size} restarts in all" if back.size > 1 else ""
        raise ProfileFormatError(
            f"{name}: the distances restart at data row {i + 2} (from {format_number(positions[i])} m back to "
            f"{format_number(positions[i + 1])} m{more}): two runs in one file? Split it, one run per file (rows "
            "only locally out of order are sorted)")


#: A distance cell with a thousands separator in a decimal-comma file (1.000 for 1000).
THOUSANDS = re.compile(r"[-+]?\d{1,3}(\.\d{3})+")
