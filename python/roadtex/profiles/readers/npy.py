"""NumPy ``.npy`` arrays: heights only, or (N, 2) distance/height pairs, with an optional JSON sidecar."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from roadtex.errors import ProfileFormatError
from roadtex.profiles.plausibility import set_distance_unit
from roadtex.profiles.readers.grid import grid_positions
from roadtex.profiles.readers.text import ReadResult
from roadtex.profiles.units import unit_factor


def sidecar_path(path: Path) -> Path:
    """The JSON file beside a ``.npy`` that holds its metadata, history and units."""
    return path.with_name(path.name + ".json")


def load_numeric_npy(path: Path, name: str) -> np.ndarray:
    """The array of a ``.npy`` file, refused unless it holds numbers (no pickles)."""
    try:
        array = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise ProfileFormatError(f"{name}: not a readable .npy array: {exc}") from None
    if array.dtype.kind not in "fiu" or array.size == 0:
        raise ProfileFormatError(f"{name}: .npy must hold numbers, got dtype {array.dtype} and {array.size} values")
    return array


def read_sidecar(path: Path, options: dict, keys: tuple[str, ...]) -> tuple[dict[str, object], list[str], dict]:
    """(metadata, history, options) of a ``.npy``: its sidecar's metadata and history, and ``options``
    with the sidecar's values filled in for ``keys`` the caller did not give."""
    metadata: dict[str, object] = {"format": "npy"}
    history: list[str] = []
    options = dict(options)
    sidecar = sidecar_path(path)
    if sidecar.exists():
        try:
            stored = json.loads(sidecar.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ProfileFormatError(f"{sidecar.name}: damaged metadata file: {exc}") from None
        metadata.update(stored.get("metadata", {}))
        history.extend(stored.get("history", []))
        for key in keys:
            if options.get(key) is None:
                options[key] = stored.get(key)
    return metadata, history, options


def read_npy(path: Path, name: str, options: dict) -> ReadResult:
    array = load_numeric_npy(path, name)
    metadata, history, options = read_sidecar(path, options, ("dx", "distance_unit", "height_unit"))
    array = array.astype(np.float64)
    height_factor = unit_factor(options.get("height_unit") or "m", "the .npy heights")
    if array.ndim == 1:   # heights only: the interval is a bare dx (m assumed)
        set_distance_unit(metadata, None)
        return grid_positions(array.size, options, name), array * height_factor, metadata, history, options.get("dx")
    if array.ndim == 2 and 2 in array.shape:
        pairs = array if array.shape[1] == 2 else array.T
        distance_factor = unit_factor(options.get("distance_unit") or "m", "the .npy distances")
        given = options.get("distance_unit")   # else metres assumed: not certain
        set_distance_unit(metadata, f"{given} (given for the file)" if given else None)
        return pairs[:, 0] * distance_factor, pairs[:, 1] * height_factor, metadata, history, options.get("dx")
    raise ProfileFormatError(f"{name}: .npy must be 1-D heights or (N, 2) distance/height pairs, got shape {array.shape}")
