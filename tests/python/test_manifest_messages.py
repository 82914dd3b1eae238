"""Every manifest error names the manifest file and, for a bad cell, its data row and column."""

from __future__ import annotations

from pathlib import Path

import polars as pl
import pytest

from roadtex.archive import read_manifest
from roadtex.errors import ManifestError

NAME = "survey_manifest.csv"


def write(tmp_path: Path, text: str) -> Path:
    (tmp_path / "a.csv").write_text("x")
    (tmp_path / "b.csv").write_text("x")
    path = tmp_path / NAME
    path.write_text(text)
    return path


@pytest.mark.parametrize("text, expected", [
    ("file\na.csv\n", "no 'path' column"),
    ("path,colour\na.csv,red\n", "unknown column"),
    ("path,site\n", "lists no runs"),
])
def test_table_errors_name_the_manifest_file(tmp_path: Path, text: str, expected: str) -> None:
    with pytest.raises(ManifestError, match=expected) as caught:
        read_manifest(write(tmp_path, text))
    assert NAME in str(caught.value)


@pytest.mark.parametrize("text, column, expected", [
    ("path,speed_kmh\na.csv,80\nb.csv,fast\n", "speed_kmh", "must be numeric"),
    ("path,speed_kmh\na.csv,80\nb.csv,0\n", "speed_kmh", "must be positive"),
    ("path,dx\na.csv,0.001\nb.csv,-0.001\n", "dx", "must be positive"),
    ("path,decimal\na.csv,.\nb.csv,;\n", "decimal", "'.' or ','"),
    ("path,site\na.csv,s1\n,s2\n", "path", "empty"),
    ("path\na.csv\nmissing.csv\n", "path", "do not exist"),
    ("path,run_id\na.csv,r1\nb.csv,r1\n", "run_id", "appears twice"),
    ("path,run_id\na.csv,r1\nb.csv,..\n", "run_id", "cannot name an output folder"),
])
def test_cell_errors_name_the_file_the_data_row_and_the_column(tmp_path: Path, text: str, column: str,
                                                               expected: str) -> None:
    with pytest.raises(ManifestError, match=expected) as caught:
        read_manifest(write(tmp_path, text))
    message = str(caught.value)
    # the bad cell is on the second data row, line 3 of the file
    assert NAME in message and "data row 2" in message and "line 3" in message and repr(column) in message


def test_a_dataframe_manifest_names_the_data_row(tmp_path: Path) -> None:
    (tmp_path / "a.csv").write_text("x")
    manifest = pl.DataFrame({"path": [str(tmp_path / "a.csv")] * 3, "speed_kmh": ["80", "80", "fast"]})
    with pytest.raises(ManifestError, match="DataFrame.*data row 3.*'speed_kmh'"):
        read_manifest(manifest)
