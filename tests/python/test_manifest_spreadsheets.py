"""Manifests as editors and spreadsheets save them (the adversarial hunt's F7): a blank line at the
end, Excel's cleared rows (``;``) and trailing empty columns (``path;run_id;;``), Windows-1252 text
(Excel's "CSV (Comma delimited)"), headers as people write them (``Path,Run ID``) and blanks around
a path. Each is read, with a note for what is left out or decoded otherwise, or refused naming the
line and what to do; a row with cells but no path is still refused."""

from __future__ import annotations

from pathlib import Path

import pytest

from roadtex.archive import read_manifest
from roadtex.errors import ManifestError, RoadtexWarning


def manifest(tmp_path: Path, content: str | bytes, name: str = "manifest.csv") -> Path:
    for data in ("a.csv", "b.csv", "b ü.csv"):
        (tmp_path / data).write_text("x")
    path = tmp_path / name
    path.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
    return path


@pytest.mark.parametrize("content", ["path,run_id\na.csv,a\n\n", "path;run_id\r\na.csv;a\r\n;\r\n",
                                     "path,run_id\na.csv,a\n , \n,\n"])
def test_wholly_empty_rows_are_left_out_with_a_note(tmp_path: Path, content: str) -> None:
    with pytest.warns(RoadtexWarning, match=r"manifest\.csv: \d wholly empty row\(s\) left out \(data row\(s\) 2"):
        table = read_manifest(manifest(tmp_path, content))
    assert table["run_id"].to_list() == ["a"]


def test_rows_after_an_empty_one_keep_their_numbers_in_messages(tmp_path: Path) -> None:
    path = manifest(tmp_path, "path,run_id\na.csv,a\n,\nmissing.csv,m\n")
    with pytest.warns(RoadtexWarning, match="wholly empty"), \
            pytest.raises(ManifestError, match=r"data row 3 \(1-based, header not counted, line 4 of the file\), "
                                               r"column 'path': no file"):
        read_manifest(path)


def test_a_row_with_cells_but_no_path_is_still_refused(tmp_path: Path) -> None:
    with pytest.raises(ManifestError, match=r"data row 2 .*column 'path': empty; every run needs a file"):
        read_manifest(manifest(tmp_path, "path,run_id\na.csv,a\n  ,b\n"))


def test_excels_empty_trailing_columns_are_left_out_with_a_note(tmp_path: Path) -> None:
    with pytest.warns(RoadtexWarning, match=r"2 empty column\(s\) without a name left out"):
        table = read_manifest(manifest(tmp_path, "path;run_id;;\r\na.csv;a;;\r\n"))
    assert table["run_id"].to_list() == ["a"] and "" not in table.columns


def test_an_unnamed_column_holding_values_and_a_name_given_twice_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ManifestError, match=r"column 3 has no name in the header but holds 'x'"):
        read_manifest(manifest(tmp_path, "path,run_id,\na.csv,a,x\n"))
    with pytest.raises(ManifestError, match=r"the header names column 'site' twice \(columns 2 and 3\)"):
        read_manifest(manifest(tmp_path, "path,site,site\na.csv,s1,s2\n"))


def test_a_windows_1252_manifest_is_read_with_a_note(tmp_path: Path) -> None:
    path = manifest(tmp_path, "path,run_id\nb ü.csv,b\n".encode("cp1252"))
    with pytest.warns(RoadtexWarning, match=r"not UTF-8 \(line 2: byte 0xfc\); read as Windows-1252"):
        table = read_manifest(path)
    assert table["path"].to_list() == [str((tmp_path / "b ü.csv").resolve())]


def test_text_neither_utf8_nor_windows_1252_is_refused_naming_the_line(tmp_path: Path) -> None:
    path = manifest(tmp_path, b"path,run_id\na.csv,a\nb\x81.csv,b\n")
    with pytest.raises(ManifestError, match=r"manifest\.csv, line 3: not UTF-8 text \(byte 0x81\), nor "
                                            r"Windows-1252: save it as CSV UTF-8"):
        read_manifest(path)


@pytest.mark.parametrize("header", ["Path,Run ID", "PATH,run-id", " path , RUN_ID "])
def test_header_names_are_matched_ignoring_case_blanks_and_underscores(tmp_path: Path, header: str) -> None:
    table = read_manifest(manifest(tmp_path, f"{header}\na.csv,first\n"))
    assert table["run_id"].to_list() == ["first"]


def test_two_columns_naming_one_are_refused_naming_both(tmp_path: Path) -> None:
    with pytest.raises(ManifestError, match=r"columns 'Run ID' and 'run_id' both name 'run_id'"):
        read_manifest(manifest(tmp_path, "path,Run ID,run_id\na.csv,x,y\n"))


def test_a_semicolon_manifests_decimal_comma_is_read_under_any_header_spelling(tmp_path: Path) -> None:
    table = read_manifest(manifest(tmp_path, "Path;Speed KMH\na.csv;80,5\n"))
    assert table["speed_kmh"].to_list() == [80.5]


def test_blanks_around_a_path_and_a_run_id_are_no_part_of_them(tmp_path: Path) -> None:
    table = read_manifest(manifest(tmp_path, "path,run_id\n  a.csv , first \nb.csv,\n"))
    assert table["path"].to_list() == [str((tmp_path / name).resolve()) for name in ("a.csv", "b.csv")]
    assert table["run_id"].to_list() == ["first", "b"]
