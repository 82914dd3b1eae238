"""ISO 25178-72 X3P files (the open XML format of areal texture instruments) read as a surface.

An X3P file is a zip archive holding ``main.xml`` (the record of the measurement: axes, data type,
grid size, where the data is) and a binary data file (usually ``bindata/data.bin``). This reader
supports what an areal texture scan of a road holds:

- Feature type ``SUR`` (a grid): X and Y axes incremental (``AxisType`` ``I``) with their
  ``Increment`` (m; ISO 25178-72 stores SI units) and ``Offset`` (m), taken as ``dx`` along the
  road (columns) and ``dy`` across it (rows); ``SizeZ`` 1.
- Z data types ``I`` (int16), ``L`` (int32), ``F`` (float32), ``D`` (float64), little-endian, X
  fastest; heights ``Offset + Increment * value`` (m; an absent ``Increment`` is 1).
- Invalid points: NaN in float data, and the valid-points mask (``ValidPointsLink``: one bit per
  point, least significant bit first, 1 = valid) when the file has one; masked points are
  drop-outs (NaN).
- The MD5 checksum of the data file (``MD5ChecksumPointData``) when the file gives one.

Not supported, refused with a :class:`~roadtex.errors.ProfileFormatError` naming the file: point
clouds and absolute X/Y axes (``PCL``, ``AxisType`` ``A``), profiles (``PRF``: read them as
profiles), several layers (``SizeZ`` > 1), inline ``DataList`` data, and any file whose zip, XML,
sizes or checksum do not hold together.

Why a reader of our own rather than SurfaceTopography (MIT, which reads X3P among ~40 formats):
X3P is a zip, an XML record and a raw array, which the standard library and numpy read in full
(reading is one ``numpy.frombuffer``); SurfaceTopography is a large package with compiled
extensions and dependencies of its own (its README once called installation "only possible on
unix/linux systems"), pulled in to read this one format, and it raises its own exception types on
bad files, where every roadtex reader raises ProfileFormatError naming the file. Its other
formats are instrument files agencies rarely hold for roads; they can be added the same way.
"""

from __future__ import annotations

import hashlib
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np

from roadtex.errors import ProfileFormatError

#: X3P Z data types and their numpy types (little-endian).
X3P_TYPES = {"I": "<i2", "L": "<i4", "F": "<f4", "D": "<f8"}
#: Zip archives start with these bytes (local file header).
ZIP_MAGIC = b"PK\x03\x04"


def local(tag: str) -> str:
    """An XML tag without its namespace."""
    return tag.rsplit("}", 1)[-1]


def child(node: ET.Element | None, *path: str) -> ET.Element | None:
    """The first descendant along ``path`` (tags without namespace), or None."""
    for name in path:
        if node is None:
            return None
        node = next((c for c in node if local(c.tag) == name), None)
    return node


def text(node: ET.Element | None, *path: str) -> str | None:
    found = child(node, *path)
    return None if found is None or found.text is None else found.text.strip()


def number(node: ET.Element | None, name: str, path: tuple[str, ...], default: float | None = None) -> float:
    value = text(node, *path)
    if value is None:
        if default is None:
            raise ProfileFormatError(f"{name}: main.xml has no {'/'.join(path)}")
        return default
    try:
        result = float(value)
    except ValueError:
        raise ProfileFormatError(f"{name}: main.xml {'/'.join(path)} is {value!r}, not a number") from None
    if not np.isfinite(result):
        raise ProfileFormatError(f"{name}: main.xml {'/'.join(path)} is {value!r}")
    return result


def read_x3p_grid(path: Path, name: str) -> tuple[np.ndarray, float, float, float, float, dict[str, object]]:
    """The grid of an X3P file: ``heights[iy, ix]`` (m, NaN where invalid), dx, dy, x0, y0 (m) and
    the metadata main.xml states (instrument, date, creator, comment). See the module docstring."""
    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as exc:
        raise ProfileFormatError(f"{name}: not an X3P file (an X3P file is a zip archive): {exc}") from None
    with archive:
        members = {info.filename.lstrip("/"): info for info in archive.infolist()}
        if "main.xml" not in members:
            raise ProfileFormatError(f"{name}: an X3P file must hold main.xml; this zip holds "
                                     f"{', '.join(sorted(members)) or 'nothing'}")
        try:
            root = ET.fromstring(archive.read(members["main.xml"]))
        except (ET.ParseError, zipfile.BadZipFile, OSError) as exc:
            raise ProfileFormatError(f"{name}: main.xml is not readable XML: {exc}") from None
        record1, record3 = child(root, "Record1"), child(root, "Record3")
        if record1 is None or record3 is None:
            raise ProfileFormatError(f"{name}: main.xml lacks Record1 or Record3 (not an ISO 25178-72 record)")
        feature = text(record1, "FeatureType")
        if feature != "SUR":
            what = {"PRF": "a profile (read it with read_profile after export)", "PCL": "a point cloud"}
            raise ProfileFormatError(f"{name}: feature type {feature!r} is {what.get(feature or '', 'not a surface')}: "
                                     "roadtex reads X3P surfaces (SUR) on a grid")
        axes = child(record1, "Axes")
        for axis in ("CX", "CY"):
            if text(axes, axis, "AxisType") != "I":
                raise ProfileFormatError(f"{name}: axis {axis} is {text(axes, axis, 'AxisType')!r}, not incremental "
                                         "('I'): absolute positions (a point list) are not supported")
        dx = number(axes, name, ("CX", "Increment"))
        dy = number(axes, name, ("CY", "Increment"))
        if dx <= 0 or dy <= 0:
            raise ProfileFormatError(f"{name}: axis increments must be positive (m), got CX {dx:g}, CY {dy:g}")
        x0 = number(axes, name, ("CX", "Offset"), 0.0)
        y0 = number(axes, name, ("CY", "Offset"), 0.0)
        dtype = text(axes, "CZ", "DataType")
        if dtype not in X3P_TYPES:
            raise ProfileFormatError(f"{name}: CZ data type {dtype!r} is not one of I, L, F, D")
        z_scale = number(axes, name, ("CZ", "Increment"), 1.0)
        z_offset = number(axes, name, ("CZ", "Offset"), 0.0)
        sizes = []
        for axis in ("SizeX", "SizeY", "SizeZ"):
            value = number(record3, name, ("MatrixDimension", axis))
            if value != int(value) or value < 1:
                raise ProfileFormatError(f"{name}: MatrixDimension/{axis} is {value:g}, not a positive whole number")
            sizes.append(int(value))
        nx, ny, nz = sizes
        if nz != 1:
            raise ProfileFormatError(f"{name}: SizeZ is {nz}: several layers are not supported (one height per point)")
        if child(record3, "DataList") is not None:
            raise ProfileFormatError(f"{name}: inline data (Record3/DataList) is not supported; a binary data file is")
        link = text(record3, "DataLink", "PointDataLink")
        if link is None or link.lstrip("/") not in members:
            raise ProfileFormatError(f"{name}: the data file {link!r} named in main.xml (DataLink/PointDataLink) is "
                                     "not in the archive")
        data = archive.read(members[link.lstrip("/")])
        expected_md5 = text(record3, "DataLink", "MD5ChecksumPointData")
        if expected_md5 and hashlib.md5(data).hexdigest().lower() != expected_md5.lower():  # noqa: S324 - the format's own checksum
            raise ProfileFormatError(f"{name}: the data file {link} fails its MD5 checksum (corrupt or altered)")
        itemsize = np.dtype(X3P_TYPES[dtype]).itemsize
        if len(data) != nx * ny * itemsize:
            raise ProfileFormatError(f"{name}: the data file {link} holds {len(data)} bytes; {nx} x {ny} points of "
                                     f"type {dtype} need {nx * ny * itemsize}")
        raw = np.frombuffer(data, dtype=X3P_TYPES[dtype]).reshape(ny, nx)
        heights = z_offset + z_scale * raw.astype(np.float64)
        mask_link = text(record3, "DataLink", "ValidPointsLink")
        if mask_link is not None:
            if mask_link.lstrip("/") not in members:
                raise ProfileFormatError(f"{name}: the valid-points file {mask_link!r} named in main.xml is not in the archive")
            bits = np.unpackbits(np.frombuffer(archive.read(members[mask_link.lstrip("/")]), dtype=np.uint8),
                                 bitorder="little")
            if bits.size < nx * ny:
                raise ProfileFormatError(f"{name}: the valid-points file {mask_link} holds {bits.size} bits for "
                                         f"{nx * ny} points")
            heights[~bits[:nx * ny].astype(bool).reshape(ny, nx)] = np.nan
    record2 = child(root, "Record2")
    metadata: dict[str, object] = {"format": "x3p", "distance_unit": "m", "height_unit": "m"}
    for key, tags in (("date", ("Date",)), ("creator", ("Creator",)), ("instrument", ("Instrument", "Model")),
                      ("manufacturer", ("Instrument", "Manufacturer")), ("comment", ("Comment",))):
        value = text(record2, *tags)
        if value:
            metadata[key] = value
    return heights, dx, dy, x0, y0, metadata
