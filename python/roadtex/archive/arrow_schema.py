"""The Arrow schema of a job's table, with each column's unit as field metadata, for polars'
Parquet writers (``arrow_schema=``).

The job's units are also in each Parquet file's key-value metadata (``units``), which polars
shows but pyarrow and pandas do not: they read the Arrow schema stored in the file. This module
builds that schema through the Arrow C data interface (a capsule named ``arrow_schema``), so that
no pyarrow is needed to write it: ``pyarrow.parquet.read_table(path).schema.field("mpd").metadata``
is then ``{b"unit": b"m"}``, and the schema's own metadata holds ``units`` as JSON.
"""

from __future__ import annotations

import ctypes
import json
import struct
from typing import Any

import polars as pl

from roadtex.archive.schemas import Columns, parquet_metadata

#: Arrow C data interface format strings of the column types the job writes (polars reads its
#: String columns back from Arrow's large UTF-8, the type its own Arrow export gives them).
FORMATS = {pl.Float64: b"g", pl.Int64: b"l", pl.Boolean: b"b", pl.String: b"U"}
#: ARROW_FLAG_NULLABLE: every column of the job's tables may hold nulls.
NULLABLE = 2


class CSchema(ctypes.Structure):
    """``struct ArrowSchema`` of the Arrow C data interface."""


RELEASE = ctypes.CFUNCTYPE(None, ctypes.POINTER(CSchema))
CSchema._fields_ = [
    ("format", ctypes.c_char_p), ("name", ctypes.c_char_p), ("metadata", ctypes.c_char_p),
    ("flags", ctypes.c_int64), ("n_children", ctypes.c_int64),
    ("children", ctypes.POINTER(ctypes.POINTER(CSchema))), ("dictionary", ctypes.POINTER(CSchema)),
    ("release", RELEASE), ("private_data", ctypes.c_void_p),
]


@RELEASE
def _release(schema: Any) -> None:
    # the buffers belong to the cached ArrowTableSchema (never freed: a dozen small schemas per
    # process); releasing only marks the struct released, as the interface requires
    schema.contents.release = RELEASE()


def encode_metadata(pairs: dict[str, str]) -> bytes:
    """Key-value metadata in the C data interface's binary layout (int32 count, then int32 length
    and bytes of each key and value, native byte order)."""
    out = [struct.pack("=i", len(pairs))]
    for key, value in pairs.items():
        for text in (key.encode(), value.encode()):
            out += [struct.pack("=i", len(text)), text]
    return b"".join(out)


class ArrowTableSchema:
    """An Arrow struct schema of named, typed, nullable columns with per-column and table metadata;
    passed as polars' ``arrow_schema``. Each export hands out a new top-level struct (the consumer
    moves it), its children shared and kept alive here."""

    def __init__(self, columns: Columns, metadata: dict[str, str]):
        self._keep: list[Any] = []
        children = []
        for name, (dtype, unit) in columns.items():
            fmt = FORMATS.get(type(dtype)) or FORMATS.get(dtype)  # type: ignore[call-overload]
            if fmt is None:
                raise TypeError(f"no Arrow format for column {name!r} of type {dtype}")
            child = CSchema(format=fmt, name=name.encode(), flags=NULLABLE, n_children=0, release=_release)
            if unit is not None:
                encoded = ctypes.create_string_buffer(encode_metadata({"unit": unit}))
                self._keep.append(encoded)
                child.metadata = ctypes.cast(encoded, ctypes.c_char_p)
            children.append(child)
        self._children = children
        self._pointers = (ctypes.POINTER(CSchema) * len(children))(*[ctypes.pointer(c) for c in children])
        self._metadata = ctypes.create_string_buffer(encode_metadata(metadata))

    def __arrow_c_schema__(self) -> object:
        top = CSchema(format=b"+s", name=b"", flags=0, n_children=len(self._children),
                      children=ctypes.cast(self._pointers, ctypes.POINTER(ctypes.POINTER(CSchema))),
                      metadata=ctypes.cast(self._metadata, ctypes.c_char_p), release=_release)
        self._keep.append(top)   # the capsule points into it: kept as long as this schema
        new_capsule = ctypes.pythonapi.PyCapsule_New
        new_capsule.restype, new_capsule.argtypes = ctypes.py_object, [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_void_p]
        return new_capsule(ctypes.addressof(top), b"arrow_schema", None)


_CACHE: dict[str, ArrowTableSchema] = {}


def arrow_schema(columns: Columns) -> ArrowTableSchema:
    """The Arrow schema of a table declared as ``column: (type, unit)``: each column's unit as
    its field metadata ``unit``, and ``units`` (JSON, column -> unit) as the schema's metadata."""
    units = {name: unit for name, (_, unit) in columns.items() if unit is not None}
    key = json.dumps([[name, str(dtype), unit] for name, (dtype, unit) in columns.items()])
    if key not in _CACHE:
        _CACHE[key] = ArrowTableSchema(columns, {"units": json.dumps(units, sort_keys=True)})
    return _CACHE[key]


def table_options(columns: Columns) -> dict[str, Any]:
    """The keyword arguments of polars' ``write_parquet`` / ``sink_parquet`` for a job's table: its
    units as the file's key-value metadata (``units``, as before) and in its Arrow schema (field
    metadata ``unit``). The frame written must have exactly ``columns``, in their order."""
    return {"metadata": parquet_metadata(columns), "arrow_schema": arrow_schema(columns)}
