"""Run ids name the runs' folders (``runs/<run_id>``), and an archive moves between machines: ids
that Windows or macOS would make one folder of (``A`` and ``a``; ``x.`` and ``x``: Windows strips a
trailing dot or blank) or cannot make at all (``con``, ``nul.txt``, ``com1``) are refused in every
manifest on every system, naming the rows; ``roadtex manifest`` makes its ids from file names so."""

from __future__ import annotations

from pathlib import Path

import polars as pl
import pytest

from roadtex.archive import build_manifest, read_manifest
from roadtex.errors import ManifestError, RoadtexWarning
from test_adversarial_manifest import write_csv


def two_runs(tmp_path: Path, first: str, second: str) -> pl.DataFrame:
    paths = [str(write_csv(tmp_path / "one.csv")), str(write_csv(tmp_path / "two.csv", 1))]
    return pl.DataFrame({"path": paths, "run_id": [first, second]})


@pytest.mark.parametrize("run_id", ["con", "PRN", "aux", "Nul", "com1", "LPT9", "con.txt", "nul.tar.gz", "aux .x"])
def test_names_windows_reserves_are_refused_naming_the_row(tmp_path: Path, run_id: str) -> None:
    with pytest.raises(ManifestError, match=r"data row 2 .*column 'run_id': run id .* is a name Windows reserves"):
        read_manifest(two_runs(tmp_path, "good", run_id))


@pytest.mark.parametrize("run_id", ["com10", "console", "lpt", "nully", "x.con"])
def test_names_that_only_look_reserved_are_taken(tmp_path: Path, run_id: str) -> None:
    assert read_manifest(two_runs(tmp_path, "good", run_id))["run_id"].to_list() == ["good", run_id]


@pytest.mark.parametrize("run_id", ["x.", "x..", "x. "])
def test_a_trailing_dot_or_blank_is_refused(tmp_path: Path, run_id: str) -> None:
    with pytest.raises(ManifestError, match=r"data row 2 .*ends in a dot or a blank, which Windows strips"):
        read_manifest(two_runs(tmp_path, "x", run_id))


def test_run_ids_equal_but_for_case_are_refused_naming_both_rows(tmp_path: Path) -> None:
    with pytest.raises(ManifestError, match=r"data row 2 .*run id 'a' and 'A' \(data row 1\) differ only in case"):
        read_manifest(two_runs(tmp_path, "A", "a"))


def test_the_manifest_command_makes_portable_ids_from_file_names(tmp_path: Path) -> None:
    for name in ("con.csv", "Site.csv", "sub/site.csv"):
        write_csv(tmp_path / name)
    with pytest.warns(RoadtexWarning) as said:
        table = build_manifest(tmp_path)
    ids = dict(zip((Path(p).relative_to(tmp_path.resolve()).as_posix() for p in table["path"]), table["run_id"]))
    assert ids == {"Site.csv": "Site", "con.csv": "con_", "sub/site.csv": "sub_site"}
    messages = " | ".join(str(w.message) for w in said)
    assert "cannot name a run's folder on Windows" in messages and "con.csv -> con_" in messages
    assert "share a name (whatever the case)" in messages and "sub/site.csv -> sub_site" in messages


@pytest.mark.parametrize("run_id", ["a:b", "lane<1>", 'say"so', "x|y", "what?", "star*"])
def test_characters_windows_refuses_in_a_name_are_refused(tmp_path: Path, run_id: str) -> None:
    with pytest.raises(ManifestError, match=r"data row 2 .*run id .* no folder name on Windows may hold"):
        read_manifest(two_runs(tmp_path, "good", run_id))


def test_the_manifest_command_replaces_them_in_ids_from_file_names(tmp_path: Path) -> None:
    write_csv(tmp_path / "A1:km 3+200.csv")   # a name Linux takes and Windows does not
    with pytest.warns(RoadtexWarning, match=r"A1:km 3\+200.csv -> A1_km 3\+200"):
        table = build_manifest(tmp_path)
    assert table["run_id"].to_list() == ["A1_km 3+200"]
