"""ISO 25178-72 X3P surfaces (roadtex.surfaces.x3p): files written here (a minimal valid main.xml
and its binary data), every data type, the valid-points mask, and broken files refused naming the
file; the manifest lists .x3p files as surfaces and the job processes them."""

from __future__ import annotations

import hashlib
import zipfile
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from roadtex.archive import ProcessingOptions, build_manifest, process
from roadtex.errors import InvalidInputError, ProfileFormatError
from roadtex.surfaces import read_surface

TYPES = {"I": "<i2", "L": "<i4", "F": "<f4", "D": "<f8"}


def main_xml(nx: int, ny: int, *, dtype: str = "D", dx: float = 0.1e-3, dy: float = 0.2e-3, z_increment: float | None = None,
             x_offset: float = 0.0, md5: str | None = None, feature: str = "SUR", x_axis: str = "I",
             mask: bool = False, link: str = "bindata/data.bin") -> str:
    z_inc = "" if z_increment is None else f"<Increment>{z_increment!r}</Increment>"
    checksum = "" if md5 is None else f"<MD5ChecksumPointData>{md5}</MD5ChecksumPointData>"
    valid = "<ValidPointsLink>bindata/valid.bin</ValidPointsLink>" if mask else ""
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<p:ISO5436_2 xmlns:p="http://www.opengps.eu/2008/ISO5436_2">
  <Record1>
    <Revision>ISO5436 - 2000</Revision>
    <FeatureType>{feature}</FeatureType>
    <Axes>
      <CX><AxisType>{x_axis}</AxisType><DataType>D</DataType><Increment>{dx!r}</Increment><Offset>{x_offset!r}</Offset></CX>
      <CY><AxisType>I</AxisType><DataType>D</DataType><Increment>{dy!r}</Increment><Offset>0</Offset></CY>
      <CZ><AxisType>A</AxisType><DataType>{dtype}</DataType>{z_inc}<Offset>0</Offset></CZ>
    </Axes>
  </Record1>
  <Record2><Date>2026-11-26T12:00:00</Date><Creator>roadtex test</Creator>
    <Instrument><Manufacturer>ACME</Manufacturer><Model>LS-3D</Model></Instrument></Record2>
  <Record3>
    <MatrixDimension><SizeX>{nx}</SizeX><SizeY>{ny}</SizeY><SizeZ>1</SizeZ></MatrixDimension>
    <DataLink><PointDataLink>{link}</PointDataLink>{checksum}{valid}</DataLink>
  </Record3>
</p:ISO5436_2>"""


def write_x3p(path: Path, values: np.ndarray, dtype: str = "D", *, valid: np.ndarray | None = None,
              with_md5: bool = True, **xml) -> Path:
    """An X3P file of ``values[iy, ix]`` (X fastest) as the standard lays it out."""
    data = np.ascontiguousarray(values, dtype=TYPES[dtype]).tobytes()
    ny, nx = values.shape
    md5 = hashlib.md5(data).hexdigest() if with_md5 else None  # noqa: S324 - the format's checksum
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("main.xml", main_xml(nx, ny, dtype=dtype, md5=md5, mask=valid is not None, **xml))
        archive.writestr("bindata/data.bin", data)
        if valid is not None:
            archive.writestr("bindata/valid.bin", np.packbits(valid.ravel().astype(np.uint8), bitorder="little").tobytes())
    return path


def test_a_float64_x3p_reads_with_its_spacings_offset_and_metadata(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    z = rng.normal(0, 0.5e-3, (6, 40))
    surface = read_surface(write_x3p(tmp_path / "scan.x3p", z, x_offset=12.5))
    np.testing.assert_array_equal(surface.heights, z)
    assert (surface.dx, surface.dy, surface.x0) == (0.1e-3, 0.2e-3, 12.5)
    assert surface.metadata["instrument"] == "LS-3D" and surface.metadata["format"] == "x3p"


@pytest.mark.parametrize("dtype", ["I", "L", "F"])
def test_integer_and_float32_data_are_scaled_by_the_z_increment(tmp_path: Path, dtype: str) -> None:
    counts = np.random.default_rng(2).integers(-2000, 2000, (4, 30))   # micrometres: a road's texture
    surface = read_surface(write_x3p(tmp_path / f"{dtype}.x3p", counts, dtype, z_increment=1e-6))
    np.testing.assert_allclose(surface.heights, counts * 1e-6, rtol=1e-6 if dtype == "F" else 1e-15)


def test_nan_and_masked_points_are_dropouts(tmp_path: Path) -> None:
    z = np.linspace(-1e-3, 1e-3, 80).reshape(4, 20)
    z[0, 3] = np.nan
    valid = np.ones_like(z, dtype=bool)
    valid[2, 5:8] = False
    surface = read_surface(write_x3p(tmp_path / "m.x3p", z, valid=valid))
    missing = np.isnan(surface.heights)
    assert missing.sum() == 4 and missing[0, 3] and missing[2, 5:8].all()
    np.testing.assert_array_equal(surface.heights[~missing], z[~missing])


def broken(tmp_path: Path, kind: str) -> Path:
    z = np.zeros((3, 10))
    path = tmp_path / f"{kind}.x3p"
    if kind == "not_zip":
        path.write_bytes(b"this is not an archive")
    elif kind == "no_main":
        with zipfile.ZipFile(path, "w") as archive:
            archive.writestr("bindata/data.bin", z.tobytes())
    elif kind == "bad_xml":
        with zipfile.ZipFile(path, "w") as archive:
            archive.writestr("main.xml", "<Record1><FeatureType>SUR")
    elif kind == "short_data":
        with zipfile.ZipFile(path, "w") as archive:
            archive.writestr("main.xml", main_xml(10, 3))
            archive.writestr("bindata/data.bin", b"\x00" * 16)
    elif kind == "bad_md5":
        data = z.tobytes()
        with zipfile.ZipFile(path, "w") as archive:
            archive.writestr("main.xml", main_xml(10, 3, md5="0" * 32))
            archive.writestr("bindata/data.bin", data)
    elif kind == "point_cloud":
        write_x3p(path, z, x_axis="A")
    elif kind == "profile":
        write_x3p(path, z, feature="PRF")
    elif kind == "missing_data":
        write_x3p(path, z, link="bindata/other.bin")
    elif kind == "bad_type":
        write_x3p(path, z)
        with zipfile.ZipFile(path, "w") as archive:
            archive.writestr("main.xml", main_xml(10, 3, dtype="Q"))
            archive.writestr("bindata/data.bin", z.tobytes())
    return path


@pytest.mark.parametrize("kind, words", [
    ("not_zip", "zip archive"), ("no_main", "main.xml"), ("bad_xml", "not readable XML"),
    ("short_data", "bytes"), ("bad_md5", "MD5"), ("point_cloud", "not incremental"),
    ("profile", "a profile"), ("missing_data", "not in the archive"), ("bad_type", "data type"),
])
def test_broken_x3p_files_are_refused_naming_the_file(tmp_path: Path, kind: str, words: str) -> None:
    path = broken(tmp_path, kind)
    with pytest.raises(ProfileFormatError, match=words) as caught:
        read_surface(path)
    assert str(caught.value).startswith(path.name)


def test_spacings_cannot_be_given_for_an_x3p_file(tmp_path: Path) -> None:
    with pytest.raises(InvalidInputError, match="states its spacings"):
        read_surface(write_x3p(tmp_path / "s.x3p", np.zeros((3, 10))), dx=1e-3)


def test_the_manifest_lists_x3p_files_as_surfaces_and_the_job_solves_them(tmp_path: Path) -> None:
    from roadtex.surfaces import synthetic_surface

    data = tmp_path / "data"
    data.mkdir()
    surface = synthetic_surface("dense_asphalt", 0.4, 0.05, 1e-3, seed=3)
    write_x3p(data / "lane.x3p", surface.heights, dx=1e-3, dy=1e-3)
    broken(data, "bad_md5")
    manifest = build_manifest(data)
    assert manifest.sort("run_id")["format"].to_list() == ["surface", "surface"]
    options = ProcessingOptions(segment_length=0.2, youngs_moduli=(2e6,), tol=1e-8, error_budget_db=None)
    summary = process(manifest, tmp_path / "out", options, quiet=True)
    assert summary.failed == 1
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet")
    assert errors["stage"].to_list() == ["read"] and "bad_md5.x3p" in errors["message"][0]
    segments = pl.read_parquet(tmp_path / "out" / "segments.parquet")
    assert set(segments["model"]) == {"line", "areal"} and (segments["run_id"] == "lane").all()
