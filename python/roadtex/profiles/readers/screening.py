"""Checks of a text table's rows and readings before they become a profile: rows whose field count
differs, drop-out codes written as numbers (``-9999``), units stated in metadata lines, and a
second run whose distances restart. Each error is a ProfileFormatError naming the file."""

from __future__ import annotations

import numpy as np

from roadtex.errors import ProfileFormatError
from roadtex.profiles.conditioning import format_number

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
