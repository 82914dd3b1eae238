"""X3P files that declare, compress or inflate what they should not (roadtex.surfaces.x3p): refused
before their members are inflated, measured in this process (bytes read from the file through the
reader's own ``open``, tracemalloc's peak), and the zip's and decompressors' own errors are the
reader's ProfileFormatError naming the file and the member. The zips are written by hand here so
that their directories can lie; a 3 GiB member is a 1 MiB deflate block of zeros repeated (each
block is flushed with Z_FULL_FLUSH, so the copies are one valid stream) and never exists inflated."""

from __future__ import annotations

import io
import struct
import tracemalloc
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pytest

from roadtex.archive import build_manifest
from roadtex.errors import ProfileFormatError
from roadtex.surfaces import read_surface, x3p
from test_x3p import main_xml

MIB = 2**20
GIB = 2**30


def deflate_repeated(block: bytes, copies: int) -> bytes:
    """A raw deflate stream of ``block`` repeated ``copies`` times, built from one compressed copy."""
    compressor = zlib.compressobj(9, zlib.DEFLATED, -15)
    once = compressor.compress(block) + compressor.flush(zlib.Z_FULL_FLUSH)
    return once * copies + compressor.flush(zlib.Z_FINISH)


def deflate(data: bytes) -> bytes:
    compressor = zlib.compressobj(9, zlib.DEFLATED, -15)
    return compressor.compress(data) + compressor.flush()


def raw_zip(path: Path, members: list[dict]) -> Path:
    """A zip written byte by byte: each member a dict of name, data (as stored in the archive),
    method, crc, size (the uncompressed size declared) and flags."""
    out = io.BytesIO()
    central = b""
    for member in members:
        name = member["name"].encode()
        data = member["data"]
        fields = (member.get("flags", 0), member.get("method", zipfile.ZIP_DEFLATED), 0, 0x21, member.get("crc", 0),
                  len(data), member["size"], len(name))
        offset = out.tell()
        out.write(struct.pack("<4sHHHHHIIIHH", b"PK\x03\x04", 20, *fields, 0) + name + data)
        central += struct.pack("<4sHHHHHHIIIHHHHHII", b"PK\x01\x02", 20, 20, *fields, 0, 0, 0, 0, 0, offset) + name
    start = out.tell()
    out.write(central + struct.pack("<4sHHHHIIH", b"PK\x05\x06", 0, 0, len(members), len(members), len(central), start, 0))
    path.write_bytes(out.getvalue())
    return path


def xml_member(text: str) -> dict:
    data = text.encode()
    return {"name": "main.xml", "data": deflate(data), "size": len(data), "crc": zlib.crc32(data)}


def honest(name: str, data: bytes, method: int = zipfile.ZIP_DEFLATED) -> dict:
    packed = {zipfile.ZIP_STORED: data, zipfile.ZIP_DEFLATED: deflate(data)}[method]
    return {"name": name, "data": packed, "size": len(data), "crc": zlib.crc32(data), "method": method}


ZEROS_3GIB = {"name": "bindata/data.bin", "data": deflate_repeated(bytes(MIB), 3 * 1024), "size": 3 * GIB}


class Counted:
    """What the reader's ``open`` returned, with the bytes read through it counted."""

    read_bytes = 0

    def __init__(self, handle):
        self.handle = handle

    def read(self, n: int = -1) -> bytes:
        data = self.handle.read(n)
        Counted.read_bytes += len(data)
        return data

    def __getattr__(self, name: str):
        return getattr(self.handle, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.handle.close()


def measured(monkeypatch: pytest.MonkeyPatch, call) -> tuple[BaseException, int, int]:
    """(the exception ``call`` raised, bytes read from the file, tracemalloc's peak in bytes)."""
    Counted.read_bytes = 0
    monkeypatch.setattr(x3p, "open", lambda path, mode="rb": Counted(open(path, mode)), raising=False)
    tracemalloc.start()
    try:
        with pytest.raises(ProfileFormatError) as caught:
            call()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return caught.value, Counted.read_bytes, peak


def bomb(tmp_path: Path, kind: str) -> Path:
    path = tmp_path / f"{kind}.x3p"
    if kind == "declares_3gib":             # the data member says what it is: 3 GiB for a 10 x 3 grid
        return raw_zip(path, [xml_member(main_xml(10, 3)), ZEROS_3GIB])
    if kind == "grid_of_3gib":              # main.xml agrees with it: 16384 x 24576 points of float64
        return raw_zip(path, [xml_member(main_xml(16384, 24576)), ZEROS_3GIB])
    if kind == "lies_about_3gib":           # the directory says 240 bytes; the data inflates to 3 GiB
        return raw_zip(path, [xml_member(main_xml(10, 3)), dict(ZEROS_3GIB, size=240)])
    spaces = deflate_repeated(b" " * MIB, 512)
    if kind == "xml_512mib":                # a main.xml of 512 MiB (blanks), declared as such
        return raw_zip(path, [{"name": "main.xml", "data": spaces, "size": 512 * MIB}])
    if kind == "xml_lies_512mib":           # ... declared as 2 kB
        return raw_zip(path, [{"name": "main.xml", "data": spaces, "size": 2048}])
    raise AssertionError(kind)


@pytest.mark.parametrize("kind, words", [
    ("declares_3gib", "declares 3221225472 bytes; 10 x 3 points of type D need 240"),
    ("grid_of_3gib", "402653184 points, beyond the"),
    ("lies_about_3gib", "inflates beyond the 240 bytes"),
    ("xml_512mib", "declares 536870912 bytes, beyond the"),
    ("xml_lies_512mib", "inflates beyond the 2048 bytes"),
])
def test_a_bomb_is_refused_before_it_is_inflated(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kind: str,
                                                 words: str) -> None:
    path = bomb(tmp_path, kind)
    assert path.stat().st_size < 4 * MIB
    error, read, peak = measured(monkeypatch, lambda: read_surface(path))
    assert str(error).startswith(path.name) and words in str(error)
    assert read < 2 * x3p.CHUNK + 256 * 1024, f"{read} bytes read from a {path.stat().st_size}-byte file"
    assert peak < 100 * MIB, f"{peak / MIB:.0f} MiB allocated to refuse it"


def test_the_manifest_of_a_folder_holding_a_bomb_lists_it_without_inflating_it(tmp_path: Path,
                                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    bomb(tmp_path, "lies_about_3gib")
    bomb(tmp_path, "declares_3gib")
    Counted.read_bytes = 0
    monkeypatch.setattr(x3p, "open", lambda path, mode="rb": Counted(open(path, mode)), raising=False)
    tracemalloc.start()
    try:
        manifest = build_manifest(tmp_path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert manifest["format"].to_list() == ["surface", "surface"]   # listed; the job records why each fails
    assert Counted.read_bytes < 2 * (2 * x3p.CHUNK + 256 * 1024)
    assert peak < 100 * MIB


def test_entity_expansion_in_main_xml_is_refused(tmp_path: Path) -> None:
    laughs = ('<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "aaaaaaaaaa">'
              + "".join(f'<!ENTITY {chr(98 + i)} "{("&" + chr(97 + i) + ";") * 10}">' for i in range(8))
              + "]><r>&i;</r>")
    path = raw_zip(tmp_path / "laughs.x3p", [xml_member(laughs)])
    with pytest.raises(ProfileFormatError, match="laughs.x3p: main.xml declares a DTD"):
        read_surface(path)


def surface_members(z: np.ndarray, **changes) -> list[dict]:
    """main.xml and a deflated data member of ``z``, the data member's fields then changed."""
    data = z.astype("<f8").tobytes()
    return [xml_member(main_xml(z.shape[1], z.shape[0])), dict(honest("bindata/data.bin", data), **changes)]


Z = np.random.default_rng(5).normal(0.0, 1e-3, (3, 10))   # metres: a road texture


@pytest.mark.parametrize("change, words", [
    ({"flags": 0x1}, "'bindata/data.bin' is encrypted"),
    ({"method": 9}, "'bindata/data.bin' is compressed with zip method 9"),          # deflate64
    ({"data": b"\xff" * 40}, "'bindata/data.bin' cannot be read"),                # not deflate: zlib.error
    ({"crc": 12345}, "fails its CRC-32"),
    ({"data": deflate(Z.tobytes())[:-6]}, "'bindata/data.bin' cannot be read"),     # a truncated stream
    ({"method": zipfile.ZIP_STORED, "data": Z.tobytes()[:200]}, r"stored \(not compressed\) but declares 200"),
])
def test_corrupt_encrypted_or_unusual_members_are_the_readers_error(tmp_path: Path, change: dict, words: str) -> None:
    path = raw_zip(tmp_path / "odd.x3p", surface_members(Z, **change))
    with pytest.raises(ProfileFormatError, match=words) as caught:
        read_surface(path)
    assert str(caught.value).startswith("odd.x3p: ")


def test_a_size_deflate_cannot_reach_is_refused_unread(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    empty = deflate(b"")   # 8 MB declared from 2 compressed bytes: a forged directory
    path = raw_zip(tmp_path / "forged.x3p", [xml_member(main_xml(1000, 1000)),
                                             {"name": "bindata/data.bin", "data": empty, "size": 8_000_000}])
    error, read, _ = measured(monkeypatch, lambda: read_surface(path))
    assert "declares 8000000 bytes from 2 compressed, beyond what deflate can inflate" in str(error)
    assert read < 64 * 1024


def test_a_zip_holding_a_member_twice_is_refused(tmp_path: Path) -> None:
    members = surface_members(Z)
    path = raw_zip(tmp_path / "twice.x3p", members + [honest("bindata/data.bin", (Z + 1).tobytes())])
    with pytest.raises(ProfileFormatError, match="holds 'bindata/data.bin' twice"):
        read_surface(path)


def test_a_directory_pointing_past_the_end_of_the_file_is_the_readers_error(tmp_path: Path) -> None:
    path = raw_zip(tmp_path / "cut.x3p", surface_members(Z))
    raw = bytearray(path.read_bytes())
    second = raw.index(b"PK\x01\x02", raw.index(b"PK\x01\x02") + 4)   # the data member's directory entry
    struct.pack_into("<I", raw, second + 42, len(raw) + 1000)            # its local header's offset
    path.write_bytes(bytes(raw))
    with pytest.raises(ProfileFormatError, match="cut.x3p: the data file 'bindata/data.bin' cannot be read"):
        read_surface(path)


@pytest.mark.parametrize("method", [zipfile.ZIP_STORED, zipfile.ZIP_BZIP2, zipfile.ZIP_LZMA])
def test_stored_bzip2_and_lzma_members_read(tmp_path: Path, method: int) -> None:
    path = tmp_path / "ok.x3p"
    with zipfile.ZipFile(path, "w", compression=method) as archive:
        archive.writestr("main.xml", main_xml(10, 3))
        archive.writestr("bindata/data.bin", Z.astype("<f8").tobytes())
    np.testing.assert_array_equal(read_surface(path).heights, Z)


def test_a_mask_member_of_another_size_than_the_grid_needs_is_refused(tmp_path: Path) -> None:
    text = main_xml(10, 3, mask=True)
    path = raw_zip(tmp_path / "mask.x3p", [xml_member(text), honest("bindata/data.bin", Z.tobytes()),
                                           honest("bindata/valid.bin", b"\xff" * 4000)])
    with pytest.raises(ProfileFormatError, match="valid-points file 'bindata/valid.bin' declares 4000 bytes; 10 x 3 "
                                                 "points need 4"):
        read_surface(path)



def test_a_forged_grid_size_is_quoted_short(tmp_path: Path) -> None:
    path = raw_zip(tmp_path / "huge.x3p", [xml_member(main_xml("1e300", 3)), honest("bindata/data.bin", Z.tobytes())])
    with pytest.raises(ProfileFormatError, match=r"declares 1e\+300 x 3 = 3e\+300 points, beyond") as caught:
        read_surface(path)
    assert len(str(caught.value)) < 300
