"""How the job reads a manifest row: which reader, with which options, and which group it belongs to."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from roadtex.archive.options import ProcessingOptions
from roadtex.profiles.readers import READ_OPTIONS

#: ``format`` values of the manifest that make a run a surface run.
SURFACE_FORMATS = ("surface", "crg", "x3p")
#: File suffixes that are surfaces whatever the manifest's ``format`` says nothing of (OpenCRG, ISO 25178-72 X3P).
SURFACE_SUFFIXES = (".crg", ".x3p")
#: Reader options of a surface run taken from its manifest row (m for dx, dy).
SURFACE_READ_OPTIONS = ("dx", "dy", "height_unit", "distance_unit")


def is_surface_run(run: dict[str, Any]) -> bool:
    """Whether a manifest row is a surface run: its ``format`` is one of :data:`SURFACE_FORMATS`, or
    its file is OpenCRG or X3P by suffix. The one test the job, the plan and the combined tables use
    (:func:`roadtex.archive.read_manifest` marks other surface files, a 2-D ``.npy`` or an x, y, z
    table listed without a format, ``"surface"`` from their content)."""
    fmt = run.get("format")
    return ((isinstance(fmt, str) and fmt.lower() in SURFACE_FORMATS)
            or Path(str(run["path"])).suffix.lower() in SURFACE_SUFFIXES)


def group_key(run: dict[str, Any]) -> str:
    """A run's (device, pavement) group, as the plan's pilots and the tables name it."""
    return f"{run.get('device') or 'any device'} / {run.get('pavement') or 'any pavement'}"


def given(value: object) -> bool:
    """Whether a manifest cell holds a value (not None, not a float NaN of a missing cell)."""
    return value is not None and not (isinstance(value, float) and np.isnan(value))


def reader_options(run: dict[str, Any], options: ProcessingOptions) -> dict[str, object]:
    """The read_profile options of one line run: the job's defaults, overridden by the run's manifest columns."""
    chosen = dict(options.reader_defaults)
    for name in READ_OPTIONS:
        if given(run.get(name)):
            chosen[name] = run[name]
    for name in ("distance_column", "height_column"):
        value = chosen.get(name)
        if isinstance(value, str) and value.strip().lstrip("-").isdigit():
            chosen[name] = int(value)   # a column index given in a CSV manifest
    return chosen


def surface_reader_options(run: dict[str, Any], options: ProcessingOptions) -> dict[str, Any]:
    """:func:`roadtex.surfaces.read_surface` options of one surface run: the job's reader defaults that
    apply to surfaces, overridden by the run's manifest columns (``dx``, ``dy`` in m, units)."""
    chosen = {k: v for k, v in options.reader_defaults.items() if k in SURFACE_READ_OPTIONS}
    for name in SURFACE_READ_OPTIONS:
        if given(run.get(name)):
            chosen[name] = run[name]
    fmt = run.get("format")
    chosen["format"] = fmt.lower() if isinstance(fmt, str) and fmt.lower() in ("crg", "x3p") else None
    return chosen
