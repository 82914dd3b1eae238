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

What a file declares is checked before anything is inflated or allocated (a 3 MB file can hold
a member that inflates to 3 GiB): main.xml's size (:data:`MAX_MAIN_XML_BYTES`), the grid's points
(:data:`MAX_POINTS`), each member's declared size against what the grid and data type need, its
compression method (stored, deflate, bzip2, LZMA; not encrypted) and a ratio its method can reach;
members are then inflated a chunk at a time and refused as soon as they exceed what they declare,
and their CRC-32 is checked. main.xml is parsed with defusedxml: a DTD or entity (an entity
expansion bomb) is refused unexpanded. Whatever zip or a decompressor raises on a damaged member
is a ProfileFormatError naming the file and the member.

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
import lzma
import struct
import xml.etree.ElementTree as ET
import zipfile
import zlib
from pathlib import Path
from typing import BinaryIO

import defusedxml.ElementTree as SafeET
import numpy as np
from defusedxml import DefusedXmlException

from roadtex.errors import ProfileFormatError
from roadtex.profiles.readers.limits import MAX_POINTS as LIMIT

#: X3P Z data types and their numpy types (little-endian).
X3P_TYPES = {"I": "<i2", "L": "<i4", "F": "<f4", "D": "<f8"}
#: Zip archives start with these bytes (local file header).
ZIP_MAGIC = b"PK\x03\x04"
#: The largest main.xml read (bytes). The record of a measurement is a few kB (inline data, the
#: one thing that makes it big, is not supported); a larger one is refused before it is inflated.
MAX_MAIN_XML_BYTES = 4 * 2**20
#: The most points an X3P surface may declare: :data:`roadtex.profiles.readers.limits.MAX_POINTS`,
#: every file's limit (2**27, 134 million; 1 GiB as float64 heights, a 4 m x 33 m lane at 1 mm). A
#: larger grid is refused before its data is inflated: split the scan.
MAX_POINTS = LIMIT
#: Deflate inflates at most 1032 times (a 258-byte match in at best 2 bits): a member that claims
#: more is damaged or forged (a zip bomb's central directory), refused unread.
DEFLATE_MAX_RATIO = 1032
#: Compression methods read: stored and deflate (read here, bounded), bzip2 and LZMA (zipfile's
#: stream, bounded by the declared size); others (deflate64, PPMd, ...) are refused by name.
METHODS = {zipfile.ZIP_STORED: "stored", zipfile.ZIP_DEFLATED: "deflate", zipfile.ZIP_BZIP2: "bzip2",
           zipfile.ZIP_LZMA: "LZMA"}
#: Bytes inflated or read at a time: the most a member's read holds beyond its declared size.
CHUNK = 2**20
#: What zip, the decompressors and the file system raise on a damaged, encrypted or unusual member.
#: (bzip2 raises OSError; encryption RuntimeError; an unknown method NotImplementedError.)
ZIP_ERRORS = (zipfile.BadZipFile, zlib.error, lzma.LZMAError, EOFError, OSError, RuntimeError, NotImplementedError,
              ValueError, struct.error)


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


def short(value: str | None) -> str:
    """A value from main.xml quoted for a message: escaped, at most 60 characters."""
    return "None" if value is None else repr(value[:60]) + (" ..." if len(value) > 60 else "")


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
        raise ProfileFormatError(f"{name}: main.xml {'/'.join(path)} is {short(value)}, not a number") from None
    if not np.isfinite(result):
        raise ProfileFormatError(f"{name}: main.xml {'/'.join(path)} is {short(value)}")
    return result


def check_member(info: zipfile.ZipInfo, name: str, what: str, size: int | None, cap: int, need: str = "") -> None:
    """Refuses a member before anything of it is inflated: encrypted, an unknown compression method,
    a declared size other than ``size`` (bytes; None: any up to ``cap``) or beyond ``cap``, or sizes
    its method cannot produce (a stored member whose two sizes differ, deflate beyond
    :data:`DEFLATE_MAX_RATIO`)."""
    member = f"{name}: {what} {info.filename!r}"
    if info.flag_bits & 0x1:
        raise ProfileFormatError(f"{member} is encrypted: roadtex reads unencrypted X3P files")
    if info.compress_type not in METHODS:
        raise ProfileFormatError(f"{member} is compressed with zip method {info.compress_type}, not one of stored, "
                                 "deflate, bzip2, LZMA: save the file again with deflate")
    if size is not None and info.file_size != size:
        raise ProfileFormatError(f"{member} declares {info.file_size} bytes; {need} need {size}")
    if info.file_size > cap:
        raise ProfileFormatError(f"{member} declares {info.file_size} bytes, beyond the {cap} read (refused unread)")
    if info.compress_type == zipfile.ZIP_STORED and info.compress_size != info.file_size:
        raise ProfileFormatError(f"{member} is stored (not compressed) but declares {info.compress_size} bytes stored "
                                 f"for {info.file_size}: a damaged zip directory")
    if info.compress_type == zipfile.ZIP_DEFLATED and info.file_size > DEFLATE_MAX_RATIO * info.compress_size + 64:
        raise ProfileFormatError(f"{member} declares {info.file_size} bytes from {info.compress_size} compressed, "
                                 f"beyond what deflate can inflate ({DEFLATE_MAX_RATIO} times): a damaged zip directory")


def inflate(handle: BinaryIO, archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> bytearray:
    """A checked member's bytes (:func:`check_member`), never more than its declared size plus one
    :data:`CHUNK` in memory: a member whose data inflates beyond (or short of) its declared size,
    or fails its CRC, raises ``zipfile.BadZipFile``."""
    out = bytearray(info.file_size)
    filled = 0
    crc = 0

    def keep(piece: bytes) -> None:
        nonlocal filled, crc
        if filled + len(piece) > len(out):
            raise zipfile.BadZipFile(f"it inflates beyond the {len(out)} bytes it declares")
        out[filled:filled + len(piece)] = piece
        filled += len(piece)
        crc = zlib.crc32(piece, crc)

    if info.compress_type in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        # read here rather than by zipfile, which silently stops at the declared size: the
        # compressed bytes are inflated a chunk at a time and any byte beyond the declared size refuses it
        handle.seek(info.header_offset)
        local = handle.read(30)
        if len(local) != 30 or local[:4] != ZIP_MAGIC:
            raise zipfile.BadZipFile("its local header is missing (a damaged zip)")
        name_length, extra_length = struct.unpack("<HH", local[26:30])
        handle.seek(info.header_offset + 30 + name_length + extra_length)
        decompressor = zlib.decompressobj(-15) if info.compress_type == zipfile.ZIP_DEFLATED else None
        left = info.compress_size
        while left > 0:
            chunk = handle.read(min(CHUNK, left))
            if not chunk:
                raise EOFError(f"the archive ends {left} compressed bytes early (truncated)")
            left -= len(chunk)
            if decompressor is None:
                keep(chunk)
                continue
            while chunk and not decompressor.eof:
                keep(decompressor.decompress(chunk, CHUNK))
                chunk = decompressor.unconsumed_tail
        if decompressor is not None and not decompressor.eof:
            raise zipfile.BadZipFile("its compressed data ends before the end of its deflate stream (truncated)")
    else:
        with archive.open(info) as stream:   # bzip2, LZMA: zipfile's stream, read no further than declared
            while piece := stream.read(min(CHUNK, len(out) - filled) or 1):
                keep(piece)
    if filled != len(out):
        raise zipfile.BadZipFile(f"it inflates to {filled} bytes, not the {len(out)} it declares")
    if crc != info.CRC:
        raise zipfile.BadZipFile("it fails its CRC-32 (corrupt)")
    return out


def read_member(handle: BinaryIO, archive: zipfile.ZipFile, info: zipfile.ZipInfo, name: str, what: str,
                size: int | None, cap: int, need: str = "") -> bytearray:
    """A member checked (:func:`check_member`) and inflated (:func:`inflate`); anything zip or a
    decompressor raises is a ProfileFormatError naming the file and the member."""
    check_member(info, name, what, size, cap, need)
    try:
        return inflate(handle, archive, info)
    except ZIP_ERRORS as exc:
        raise ProfileFormatError(f"{name}: {what} {info.filename!r} cannot be read: "
                                 f"{str(exc)[:200] or type(exc).__name__}") from None


def read_x3p_grid(path: Path, name: str) -> tuple[np.ndarray, float, float, float, float, dict[str, object]]:
    """The grid of an X3P file: ``heights[iy, ix]`` (m, NaN where invalid), dx, dy, x0, y0 (m) and
    the metadata main.xml states (instrument, date, creator, comment). See the module docstring.

    What the file declares is checked before anything is inflated or allocated: main.xml's size
    (at most :data:`MAX_MAIN_XML_BYTES`), the grid's points (at most :data:`MAX_POINTS`), each
    member's declared size against the size the grid and data type need, its compression method
    and ratio; members are inflated a chunk at a time and refused as soon as they exceed their
    declared size. main.xml is parsed by defusedxml (no entity expansion, no external entities)."""
    try:
        handle = open(path, "rb")   # closed by the with below; a test counts the bytes read through it
    except OSError as exc:
        raise ProfileFormatError(f"{name}: cannot be opened: {exc.strerror or exc}") from None
    with handle:
        try:
            archive = zipfile.ZipFile(handle)
        except ZIP_ERRORS as exc:
            raise ProfileFormatError(f"{name}: not an X3P file (an X3P file is a zip archive): "
                                     f"{str(exc)[:200]}") from None
        with archive:
            return read_archive(handle, archive, name)


def read_archive(handle: BinaryIO, archive: zipfile.ZipFile, name: str
                 ) -> tuple[np.ndarray, float, float, float, float, dict[str, object]]:
    """:func:`read_x3p_grid` on an open zip."""
    members: dict[str, zipfile.ZipInfo] = {}
    for info in archive.infolist():
        key = info.filename.lstrip("/")
        if key in members:   # which of the two is the data? Neither is guessed
            raise ProfileFormatError(f"{name}: the zip holds {key!r} twice (a damaged or altered archive)")
        members[key] = info
    if "main.xml" not in members:
        listed = sorted(members)
        raise ProfileFormatError(f"{name}: an X3P file must hold main.xml; this zip holds "
                                 f"{', '.join(repr(m[:80]) for m in listed[:10]) or 'nothing'}"
                                 f"{f' and {len(listed) - 10} more' if len(listed) > 10 else ''}")
    xml = read_member(handle, archive, members["main.xml"], name, "the record", None, MAX_MAIN_XML_BYTES)
    try:
        root = SafeET.fromstring(bytes(xml), forbid_dtd=True)
    except DefusedXmlException as exc:
        raise ProfileFormatError(f"{name}: main.xml declares a DTD or entities ({type(exc).__name__}), which an "
                                 "X3P record has no use for: refused unexpanded") from None
    except ET.ParseError as exc:
        raise ProfileFormatError(f"{name}: main.xml is not readable XML: {exc}") from None
    del xml
    record1, record3 = child(root, "Record1"), child(root, "Record3")
    if record1 is None or record3 is None:
        raise ProfileFormatError(f"{name}: main.xml lacks Record1 or Record3 (not an ISO 25178-72 record)")
    feature = text(record1, "FeatureType")
    if feature != "SUR":
        what = {"PRF": "a profile (read it with read_profile after export)", "PCL": "a point cloud"}
        raise ProfileFormatError(f"{name}: feature type {short(feature)} is {what.get(feature or '', 'not a surface')}: "
                                 "roadtex reads X3P surfaces (SUR) on a grid")
    axes = child(record1, "Axes")
    for axis in ("CX", "CY"):
        if text(axes, axis, "AxisType") != "I":
            raise ProfileFormatError(f"{name}: axis {axis} is {short(text(axes, axis, 'AxisType'))}, not incremental "
                                     "('I'): absolute positions (a point list) are not supported")
    dx = number(axes, name, ("CX", "Increment"))
    dy = number(axes, name, ("CY", "Increment"))
    if dx <= 0 or dy <= 0:
        raise ProfileFormatError(f"{name}: axis increments must be positive (m), got CX {dx:g}, CY {dy:g}")
    x0 = number(axes, name, ("CX", "Offset"), 0.0)
    y0 = number(axes, name, ("CY", "Offset"), 0.0)
    dtype = text(axes, "CZ", "DataType")
    if dtype not in X3P_TYPES:
        raise ProfileFormatError(f"{name}: CZ data type {short(dtype)} is not one of I, L, F, D")
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
    if nx * ny > MAX_POINTS:
        def shown(count: int) -> str:   # a forged 1e300 is no 301-digit message
            return str(count) if count < 10**15 else f"{float(count):.3g}"
        raise ProfileFormatError(f"{name}: main.xml declares {shown(nx)} x {shown(ny)} = {shown(nx * ny)} points, beyond "
                                 f"the {MAX_POINTS} an X3P surface may hold here (refused before its data is inflated): "
                                 "split the scan")
    if child(record3, "DataList") is not None:
        raise ProfileFormatError(f"{name}: inline data (Record3/DataList) is not supported; a binary data file is")
    link = text(record3, "DataLink", "PointDataLink")
    if link is None or link.lstrip("/") not in members:
        raise ProfileFormatError(f"{name}: the data file {short(link)} named in main.xml (DataLink/PointDataLink) is "
                                 "not in the archive")
    itemsize = np.dtype(X3P_TYPES[dtype]).itemsize
    need = nx * ny * itemsize
    data = read_member(handle, archive, members[link.lstrip("/")], name, "the data file", need, need,
                       f"{nx} x {ny} points of type {dtype}")
    expected_md5 = text(record3, "DataLink", "MD5ChecksumPointData")
    if expected_md5 and hashlib.md5(data).hexdigest().lower() != expected_md5.lower():  # noqa: S324 - the format's own checksum
        raise ProfileFormatError(f"{name}: the data file {short(link)} fails its MD5 checksum (corrupt or altered)")
    heights = np.frombuffer(data, dtype=X3P_TYPES[dtype]).reshape(ny, nx).astype(np.float64)
    del data
    heights *= z_scale
    heights += z_offset
    mask_link = text(record3, "DataLink", "ValidPointsLink")
    if mask_link is not None:
        if mask_link.lstrip("/") not in members:
            raise ProfileFormatError(f"{name}: the valid-points file {short(mask_link)} named in main.xml is not in the "
                                     "archive")
        mask_bytes = -(-nx * ny // 8)   # one bit a point, padded to a whole byte (a word at most: 8 bytes more)
        info = members[mask_link.lstrip("/")]
        if not mask_bytes <= info.file_size <= mask_bytes + 8:
            raise ProfileFormatError(f"{name}: the valid-points file {short(mask_link)} declares {info.file_size} bytes; "
                                     f"{nx} x {ny} points need {mask_bytes} (one bit a point)")
        packed = read_member(handle, archive, info, name, "the valid-points file", None, mask_bytes + 8)
        bits = np.unpackbits(np.frombuffer(packed, dtype=np.uint8), count=nx * ny, bitorder="little")
        heights[~bits.astype(bool).reshape(ny, nx)] = np.nan
    record2 = child(root, "Record2")
    metadata: dict[str, object] = {"format": "x3p", "distance_unit": "m", "height_unit": "m"}
    for key, tags in (("date", ("Date",)), ("creator", ("Creator",)), ("instrument", ("Instrument", "Model")),
                      ("manufacturer", ("Instrument", "Manufacturer")), ("comment", ("Comment",))):
        value = text(record2, *tags)
        if value:
            metadata[key] = value
    return heights, dx, dy, x0, y0, metadata
