"""Writing profiles so that :func:`roadtex.read_profile` gives them back bit for bit."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import polars as pl

from roadtex.errors import InvalidInputError
from roadtex.profiles.profile import Profile
from roadtex.profiles.readers.delimited import ROADTEX_TAG
from roadtex.profiles.readers.npy import sidecar_path


def json_safe(metadata: dict[str, object]) -> dict[str, object]:
    safe: dict[str, object] = {}
    for key, value in metadata.items():
        try:
            json.dumps(value, allow_nan=False)
            safe[str(key)] = value
        except (TypeError, ValueError):
            safe[str(key)] = str(value)
    return safe


def write_profile(profile: Profile, path: str | Path, format: str | None = None) -> Path:
    """Writes ``profile`` so that :func:`read_profile` gives back the same heights, positions
    (bit for bit), dx, metadata and history (plus one line recording the read).

    Formats (``None`` takes it from the suffix: ``.csv``/``.txt``/``.tsv``, ``.npy``, ``.parquet``):
    ``"csv"`` with a ``# roadtex-profile: {json}`` first line and columns ``distance (m)``,
    ``height (m)`` (tab-separated for ``.tsv``); ``"npy"`` as an (N, 2) array of metres plus a
    ``<file>.npy.json`` sidecar for the metadata; ``"parquet"`` with columns ``distance_m``,
    ``height_m`` and the metadata in the file's key-value metadata. Metadata values that are not
    JSON types are written as strings. Drop-outs are written NaN.

    Returns:
        The path written.
    """
    if not isinstance(profile, Profile):
        raise InvalidInputError(f"profile must be a roadtex Profile, got {type(profile).__name__}")
    file = Path(path)
    suffix = file.suffix.lower()
    if format is None:
        format = {".csv": "csv", ".txt": "csv", ".tsv": "csv", ".npy": "npy", ".parquet": "parquet",
                  ".pq": "parquet"}.get(suffix)
        if format is None:
            raise InvalidInputError(f"cannot tell the format from the suffix {suffix!r}: give format='csv', 'npy' or 'parquet'")
    if format not in ("csv", "npy", "parquet"):
        raise InvalidInputError(f"write_profile writes 'csv', 'npy' or 'parquet', got {format!r}")
    stored = {"metadata": json_safe(profile.metadata), "history": list(profile.history), "dx": profile.dx}
    positions = np.asarray(profile.positions)
    heights = np.asarray(profile.heights)
    if format == "csv":
        separator = "\t" if suffix == ".tsv" else ","
        frame = pl.DataFrame({"distance (m)": positions, "height (m)": heights})
        with file.open("w", encoding="utf-8", newline="\n") as handle:
            handle.write(f"# {ROADTEX_TAG}: {json.dumps(stored)}\n")
            frame.write_csv(handle, separator=separator, float_scientific=None)
    elif format == "npy":
        np.save(file, np.column_stack([positions, heights]), allow_pickle=False)
        sidecar_path(file).write_text(json.dumps({**stored, "distance_unit": "m", "height_unit": "m"}), encoding="utf-8")
    else:
        frame = pl.DataFrame({"distance_m": positions, "height_m": heights})
        frame.write_parquet(file, metadata={ROADTEX_TAG: json.dumps(stored)})
    return file
