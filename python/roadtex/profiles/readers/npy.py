"""NumPy ``.npy`` arrays: heights only, or (N, 2) distance/height pairs, with an optional JSON sidecar."""

from __future__ import annotations

import difflib
import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from roadtex.errors import ProfileFormatError
from roadtex.profiles.plausibility import set_distance_unit
from roadtex.profiles.readers.grid import grid_positions
from roadtex.profiles.readers.limits import check_points
from roadtex.profiles.readers.text import ReadResult, bare_interval_unit
from roadtex.profiles.units import unit_factor


def sidecar_path(path: Path) -> Path:
    """The JSON file beside a ``.npy`` that holds its metadata, history and units."""
    return path.with_name(path.name + ".json")


def npy_header(path: Path, name: str) -> tuple[tuple[int, ...], np.dtype]:
    """(shape, dtype) a ``.npy`` file's header claims, checked against the bytes the file holds.

    Read before the array so that a damaged or hostile header (a 208-byte file claiming 10^12
    values) is refused as that file's fault rather than allocated (a MemoryError would stop a job);
    a zip archive (``numpy.savez`` output saved as ``.npy``) and a header numpy cannot parse are
    refused with the file's name too.
    """
    fmt = np.lib.format
    try:
        with open(path, "rb") as handle:
            start = handle.read(6)
            if start.startswith(b"PK\x03\x04"):
                raise ProfileFormatError(f"{name}: a .npz archive (zip, numpy.savez), not a .npy array: load it "
                                         "with numpy.load and numpy.save the array to read")
            if start != fmt.MAGIC_PREFIX:
                raise ProfileFormatError(f"{name}: not a .npy array (it does not start with numpy's magic bytes)")
            handle.seek(0)
            version = fmt.read_magic(handle)
            reader = fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0
            shape, _, dtype = reader(handle, max_header_size=10_000)
            data_bytes = path.stat().st_size - handle.tell()
    except ProfileFormatError:
        raise
    except Exception as exc:  # noqa: BLE001 - numpy's header parser raises ValueError, SyntaxError, TokenError...
        raise ProfileFormatError(f"{name}: not a readable .npy array: damaged header "
                                 f"({type(exc).__name__}: {str(exc)[:120]!r})") from None
    count = 1
    for length in shape:
        count *= int(length)
    claimed = count * dtype.itemsize
    if dtype.kind in "fiu" and claimed > data_bytes:
        raise ProfileFormatError(f"{name}: damaged .npy: its header claims shape {shape} of {dtype} "
                                 f"({claimed} bytes) but the file holds {data_bytes} bytes of data")
    return shape, dtype


def load_numeric_npy(path: Path, name: str) -> np.ndarray:
    """The array of a ``.npy`` file, refused unless it holds numbers (no pickles), its header's
    shape fits in the file (:func:`npy_header`) and declares at most
    :data:`~roadtex.profiles.readers.limits.MAX_POINTS` values (a sparse file can hold 16 GB of
    zeros in a few kB of disk): both checked before the array is read."""
    shape, dtype = npy_header(path, name)
    if dtype.kind not in "fiu":
        raise ProfileFormatError(f"{name}: .npy must hold numbers, got dtype {dtype}")
    check_points(name, math.prod(int(length) for length in shape), f"its .npy header's shape {shape}")
    try:
        array = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise ProfileFormatError(f"{name}: not a readable .npy array: {exc}") from None
    if array.dtype.kind not in "fiu" or array.size == 0:
        raise ProfileFormatError(f"{name}: .npy must hold numbers, got dtype {array.dtype} and {array.size} values")
    return array


def read_sidecar(path: Path, options: dict,
                 keys: tuple[str, ...]) -> tuple[dict[str, object], list[str], dict, dict[str, str]]:
    """(metadata, history, options, sources) of a ``.npy``: its sidecar's metadata and history,
    ``options`` with the sidecar's values filled in for ``keys`` the caller did not give, and where
    each of ``keys`` that has a value came from ("given for the file" or "the file's sidecar"), for
    the labels that state a unit's provenance."""
    metadata: dict[str, object] = {"format": "npy"}
    history: list[str] = []
    options = dict(options)
    sources = {key: "given for the file" for key in keys if options.get(key) is not None}
    sidecar = sidecar_path(path)
    if sidecar.exists():
        stored = load_sidecar(sidecar)
        metadata.update(stored.get("metadata", {}))
        history.extend(stored.get("history", []))
        for key in keys:
            if options.get(key) is None:
                options[key] = stored.get(key)
                if options[key] is not None:
                    sources[key] = "the file's sidecar"
    return metadata, history, options, sources


#: The largest sidecar read (bytes): spacings, units, metadata and a history are a few kB.
MAX_SIDECAR_BYTES = 2**20
#: The keys a sidecar may hold: the spacings along and across the road (m), the units of the
#: distances and heights, the metadata and the history. Any other is refused (a ``"DY"`` or
#: ``"dy_mm"`` was ignored without a word, and dy taken as dx).
SIDECAR_KEYS = ("dx", "dy", "distance_unit", "height_unit", "metadata", "history")


def load_sidecar(sidecar: Path) -> dict:
    """A sidecar's JSON object, its size checked before it is read (at most
    :data:`MAX_SIDECAR_BYTES`) and its shape by :func:`stored_record`; anything else is a
    ProfileFormatError naming the sidecar."""
    def damaged(why: str) -> ProfileFormatError:
        return ProfileFormatError(f"{sidecar.name}: damaged metadata file: {why}")

    try:
        size = sidecar.stat().st_size
        if size > MAX_SIDECAR_BYTES:
            raise damaged(f"{size} bytes, beyond the {MAX_SIDECAR_BYTES} a sidecar of spacings, units and metadata "
                          "may hold (refused unread)")
        text = sidecar.read_text(encoding="utf-8")
    except (UnicodeDecodeError, OSError) as exc:
        raise damaged(str(exc)[:200]) from None
    stored = stored_record(text, damaged)
    unknown = [key for key in stored if key not in SIDECAR_KEYS]
    if unknown:
        hints = []
        for key in unknown[:5]:
            close = difflib.get_close_matches(str(key).lower(), SIDECAR_KEYS, n=1, cutoff=0.5)
            hints.append(f"{str(key)[:40]!r}" + (f" (did you mean {close[0]!r}?)" if close else ""))
        more = f" and {len(unknown) - 5} more" if len(unknown) > 5 else ""
        raise ProfileFormatError(f"{sidecar.name}: unknown key(s) {', '.join(hints)}{more}; a sidecar holds "
                                 f"{', '.join(SIDECAR_KEYS)} (dx and dy in m; the array's shape is its own): "
                                 "correct or remove the key")
    return stored


def stored_record(text: str, damaged: Callable[[str], ProfileFormatError]) -> dict:
    """The record roadtex stores with a file (a ``.npy``'s sidecar, a CSV's ``# roadtex-profile:``
    line, a Parquet file's key-value metadata) as a dict, its shape checked: an object whose
    ``metadata`` is an object (any JSON values, as :func:`~roadtex.write_profile` writes them),
    whose ``history`` is a list of text and whose units are text. ``damaged(why)`` makes the error
    naming the file (before: dict's and json's own exceptions, or a history string split into
    characters)."""
    try:
        stored = json.loads(text)
    except ValueError as exc:
        raise damaged(str(exc)[:200]) from None
    except RecursionError:
        raise damaged("nested too deeply") from None
    if not isinstance(stored, dict):
        raise damaged(f"a JSON object is expected (dx, dy, height_unit, metadata, history), got {type(stored).__name__}")
    meta = stored.get("metadata", {})
    if not isinstance(meta, dict):
        raise damaged(f"'metadata' must be an object, got {type(meta).__name__}")
    history = stored.get("history", [])
    if not isinstance(history, list) or not all(isinstance(line, str) for line in history):
        raise damaged("'history' must be a list of text lines")
    for key in ("height_unit", "distance_unit"):
        if stored.get(key) is not None and not isinstance(stored[key], str):
            raise damaged(f"{key!r} must be a unit's name ('m', 'mm', 'um'), got {stored[key]!r:.40}")
    return stored


def read_npy(path: Path, name: str, options: dict) -> ReadResult:
    array = load_numeric_npy(path, name)
    metadata, history, options, sources = read_sidecar(path, options, ("dx", "distance_unit", "height_unit"))
    unit_source = sources.get("distance_unit", "")
    array = array.astype(np.float64)
    height_factor = unit_factor(options.get("height_unit") or "m", "the .npy heights")
    if array.ndim == 1:   # heights only: the interval is a bare dx (m), certain when m is given for the file
        set_distance_unit(metadata, bare_interval_unit(options.get("distance_unit"), unit_source))
        return grid_positions(array.size, options, name), array * height_factor, metadata, history, options.get("dx")
    if array.ndim == 2 and 2 in array.shape:
        pairs = array if array.shape[1] == 2 else array.T
        distance_factor = unit_factor(options.get("distance_unit") or "m", "the .npy distances")
        given = options.get("distance_unit")   # else metres assumed: not certain
        set_distance_unit(metadata, f"{given} ({unit_source})" if given else None)
        return pairs[:, 0] * distance_factor, pairs[:, 1] * height_factor, metadata, history, options.get("dx")
    raise ProfileFormatError(f"{name}: .npy must be 1-D heights or (N, 2) distance/height pairs, got shape {array.shape}")
