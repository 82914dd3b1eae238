"""``<file>.npy.json`` sidecars as an attacker writes them (issue 38's hunt): a list, a null, a
string for the metadata, a history string (split into characters before), a number for a unit,
a 100,000-deep nesting (RecursionError), an oversized file; and metadata a manifest cannot hold
as it was (a list beside text made polars refuse the whole manifest). Each is the reader's
ProfileFormatError naming the sidecar, or a manifest cell written as text."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import roadtex
from roadtex.archive import build_manifest
from roadtex.errors import ProfileFormatError, RoadtexWarning
from roadtex.profiles.readers.npy import MAX_SIDECAR_BYTES
from roadtex.surfaces import read_surface

LINE = np.random.default_rng(0).normal(0.0, 1e-3, 500)
GRID = np.random.default_rng(1).normal(0.0, 1e-3, (6, 500))


@pytest.mark.parametrize("text, words", [
    ("[1, 2]", "a JSON object is expected"),
    ("null", "a JSON object is expected"),
    ('{"dx": 0.001, "metadata": "abc"}', "'metadata' must be an object, got str"),
    ('{"dx": 0.001, "metadata": [1, 2]}', "'metadata' must be an object, got list"),
    ('{"dx": 0.001, "history": "abc"}', "'history' must be a list of text lines"),
    ('{"dx": 0.001, "history": [1]}', "'history' must be a list of text lines"),
    ('{"dx": 0.001, "height_unit": 5}', "'height_unit' must be a unit's name"),
    ('{"dx": 0.001, "distance_unit": {"a": 1}}', "'distance_unit' must be a unit's name"),
    ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
])
@pytest.mark.parametrize("kind", ["profile", "surface"])
def test_a_malformed_sidecar_is_the_readers_error_naming_it(tmp_path: Path, kind: str, text: str, words: str) -> None:
    path = tmp_path / f"{kind}.npy"
    np.save(path, LINE if kind == "profile" else GRID)
    (tmp_path / f"{kind}.npy.json").write_text(text, encoding="utf-8")
    with pytest.raises(ProfileFormatError, match=rf"{kind}\.npy\.json: damaged metadata file: {words}"):
        (roadtex.read_profile if kind == "profile" else read_surface)(path)


def test_an_oversized_sidecar_is_refused_unread(tmp_path: Path) -> None:
    np.save(tmp_path / "big.npy", LINE)
    (tmp_path / "big.npy.json").write_text('{"dx": 0.001, "comment": "' + "x" * MAX_SIDECAR_BYTES + '"}', encoding="utf-8")
    with pytest.raises(ProfileFormatError, match=rf"big\.npy\.json: damaged metadata file: \d+ bytes, beyond the "
                                                 rf"{MAX_SIDECAR_BYTES}"):
        roadtex.read_profile(tmp_path / "big.npy")


def test_a_written_profile_with_structured_metadata_reads_back(tmp_path: Path) -> None:
    profile = roadtex.Profile(LINE, 1e-3 * np.arange(LINE.size), 1e-3, {"site": "S1", "survey": {"lane": 2, "runs": [1, 2]}})
    back = roadtex.read_profile(roadtex.write_profile(profile, tmp_path / "p.npy"))
    assert back.metadata["survey"] == {"lane": 2, "runs": [1, 2]}


def test_the_manifest_writes_metadata_it_cannot_hold_as_text(tmp_path: Path) -> None:
    for name, meta in (("a", {"site": [1, 2], "date": {"day": 1}, "speed_kmh": "fast"}),
                       ("b", {"site": "S1", "date": 2020, "speed_kmh": 80})):
        np.save(tmp_path / f"{name}.npy", LINE)
        (tmp_path / f"{name}.npy.json").write_text(json.dumps({"dx": 0.001, "metadata": meta}), encoding="utf-8")
    with pytest.warns(RoadtexWarning, match=r"a\.npy: its metadata's speed_kmh 'fast' is not a number"):
        manifest = build_manifest(tmp_path)
    rows = manifest.sort("run_id").select("site", "date", "speed_kmh").rows()
    assert rows == [("[1, 2]", '{"day": 1}', None), ("S1", "2020", 80.0)]


@pytest.mark.parametrize("record, words", [
    ("[1]", "a JSON object is expected"), ('{"history": "abc"}', "'history' must be a list of text lines"),
    ('{"metadata": 5}', "'metadata' must be an object, got int"), ("{oops", "Expecting property name"),
])
def test_the_record_stored_in_a_csv_or_parquet_file_is_checked_as_a_sidecar(tmp_path: Path, record: str,
                                                                             words: str) -> None:
    import polars as pl

    csv = tmp_path / "p.csv"
    csv.write_text(f"# roadtex-profile: {record}\ndistance (m),height (m)\n"
                   + "".join(f"{i * 1e-3},{z}\n" for i, z in enumerate(LINE)), encoding="utf-8")
    with pytest.raises(ProfileFormatError, match=rf"p\.csv: damaged roadtex-profile header line: {words}"):
        roadtex.read_profile(csv)
    parquet = tmp_path / "p.parquet"
    pl.DataFrame({"distance_m": 1e-3 * np.arange(LINE.size), "height_m": LINE}).write_parquet(
        parquet, metadata={"roadtex-profile": record})
    with pytest.raises(ProfileFormatError, match=rf"p\.parquet: damaged roadtex-profile metadata: {words}"):
        roadtex.read_profile(parquet)


@pytest.mark.parametrize("key, hint", [("DY", " (did you mean 'dy'?)"), ("dy_mm", " (did you mean 'dy'?)"),
                                       ("shape", ""), ("Height_Unit", " (did you mean 'height_unit'?)")])
@pytest.mark.parametrize("kind", ["profile", "surface"])
def test_an_unknown_sidecar_key_is_refused_naming_the_sidecar_and_the_key(tmp_path: Path, kind: str, key: str,
                                                                           hint: str) -> None:
    # {"dx": 0.5e-3, "DY": 1e-3} gave dy = dx = 0.5 mm without a word
    path = tmp_path / f"{kind}.npy"
    np.save(path, LINE if kind == "profile" else GRID)
    (tmp_path / f"{kind}.npy.json").write_text(json.dumps({"dx": 0.5e-3, key: [6, 500] if key == "shape" else 1e-3}),
                                               encoding="utf-8")
    with pytest.raises(ProfileFormatError, match=rf"^{kind}\.npy\.json: unknown key\(s\) '{key}'"
                                                 rf"{re.escape(hint)}; a sidecar holds dx, dy, distance_unit"):
        (roadtex.read_profile if kind == "profile" else read_surface)(path)


def test_every_key_a_sidecar_may_hold_is_read(tmp_path: Path) -> None:
    np.save(tmp_path / "scan.npy", GRID)
    (tmp_path / "scan.npy.json").write_text(json.dumps({
        "dx": 0.5e-3, "dy": 1e-3, "distance_unit": "m", "height_unit": "mm", "metadata": {"site": "S1"},
        "history": ["scanned"]}), encoding="utf-8")
    surface = read_surface(tmp_path / "scan.npy")
    assert (surface.dx, surface.dy, surface.metadata["site"]) == (0.5e-3, 1e-3, "S1")
    assert np.allclose(surface.heights, GRID * 1e-3) and surface.history[0] == "scanned"
