"""Files that were read to silently wrong numbers (the readers' adversarial findings): two runs in
one file, numeric drop-out codes, decimal commas in a comma-delimited file without a header, empty
cells at the ends of heights-only files, units stated in metadata lines, thousands separators and
rows with one field too many. Each is now read to the numbers written, or refused naming the file
and the line."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex.errors import ImplausibleTextureWarning, InvalidInputError, ProfileFormatError

DX_MM = 0.5


def texture(n: int, seed: int = 4) -> np.ndarray:
    """Heights (mm, three decimals) of an irregular 1.5 mm texture: no value repeats by design."""
    rng = np.random.default_rng(seed)
    x = np.arange(n) * DX_MM
    z = 1.5 * np.sin(2 * np.pi * x / 7.3) + 0.6 * np.cos(2 * np.pi * x / 2.9) + 0.2 * rng.standard_normal(n)
    return np.round(z, 3)


def read(path: Path, **options: object) -> roadtex.Profile:
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleTextureWarning)
        return roadtex.read_profile(path, **options)


def rows(x: np.ndarray, z: list[str] | np.ndarray, separator: str = ",") -> str:
    return "".join(f"{a:.3f}{separator}{b}\n" for a, b in zip(x, z))


# 1. Two runs in one file, the second restarting at distance 0

def test_a_second_run_restarting_at_zero_is_refused_naming_the_row(tmp_path: Path) -> None:
    n = 1200
    x = 62.5 + np.arange(n) * DX_MM
    half = n // 2
    # the second pass restarts at 0, 0.075 mm off the first one's grid: sorted, the two would interleave
    restarted = np.concatenate([x[:half], x[half:] - x[half] + 0.075])
    path = tmp_path / "two_passes.csv"
    path.write_text("distance (mm),height (mm)\n" + rows(restarted, texture(n)))
    with pytest.raises(ProfileFormatError, match=rf"two_passes\.csv: the distances restart at data row {half + 1} "
                                                 r"\(from 0\.362 m back to 7\.5e-05 m\): two runs in one file\? Split"):
        read(path)
    with pytest.raises(ProfileFormatError, match="restart at data row"):
        read(path, sort=False)


def test_a_file_written_in_reverse_and_rows_swapped_locally_are_still_sorted(tmp_path: Path) -> None:
    n = 800
    x, z = np.arange(n) * DX_MM, texture(n)
    reverse = tmp_path / "reverse.csv"
    reverse.write_text("distance (mm),height (mm)\n" + rows(x[::-1], z[::-1]))
    order = np.arange(n)
    order[[100, 101]], order[[500, 503]] = order[[101, 100]], order[[503, 500]]
    swapped = tmp_path / "swapped.csv"
    swapped.write_text("distance (mm),height (mm)\n" + rows(x[order], z[order]))
    for path in (reverse, swapped):
        profile = read(path)
        np.testing.assert_allclose(profile.positions, x * 1e-3, atol=1e-12)
        np.testing.assert_allclose(profile.heights, z * 1e-3, atol=1e-12)
        assert "sorted" in profile.history[-1]


# 2. Drop-out codes written as numbers

def coded_file(tmp_path: Path, code: str, n: int = 1600) -> tuple[Path, np.ndarray, np.ndarray]:
    """A µm file with 12 stretches of 3 to 20 readings written as ``code``: the path, the true
    heights (µm) and the mask of coded readings."""
    z_um = np.round(texture(n) * 1e3, 1)
    rng = np.random.default_rng(7)
    coded = np.zeros(n, dtype=bool)
    for start in rng.choice(np.arange(20, n - 40), 12, replace=False):
        coded[start:start + int(rng.integers(3, 21))] = True
    cells = [code if c else f"{v:.1f}" for v, c in zip(z_um, coded)]
    path = tmp_path / f"coded{code}.csv"
    path.write_text("distance [mm];height [µm]\n" + rows(np.arange(n) * DX_MM, cells, ";"))
    return path, z_um, coded


@pytest.mark.parametrize("code", ["-9999", "-999", "9999", "-99999"])
def test_common_dropout_codes_in_stretches_are_drop_outs_with_a_note(tmp_path: Path, code: str) -> None:
    path, z_um, coded = coded_file(tmp_path, code)
    profile = read(path)
    assert np.array_equal(np.isnan(profile.heights), coded)
    np.testing.assert_allclose(profile.heights[~coded], z_um[~coded] * 1e-6, atol=1e-12)
    assert any(f"{coded.sum()} readings of {code} " in line and "drop-out code" in line for line in profile.history)


def test_a_dropout_value_given_makes_those_readings_drop_outs(tmp_path: Path) -> None:
    path, z_um, coded = coded_file(tmp_path, "-555.5")
    assert not np.isnan(read(path).heights).any()   # not a common code: texture unless stated
    profile = read(path, dropout_value=-555.5)
    assert np.array_equal(np.isnan(profile.heights), coded)
    assert any(f"{coded.sum()} readings equal to the dropout_value -555.5" in line for line in profile.history)
    np.save(tmp_path / "h.npy", z_um * 1e-6)
    with pytest.raises(InvalidInputError, match=r"h\.npy: dropout_value is for text files"):
        roadtex.read_profile(tmp_path / "h.npy", dx=0.5e-3, dropout_value=-9999)


def test_a_code_value_that_is_as_frequent_as_its_neighbours_stays_texture(tmp_path: Path) -> None:
    """Integer µm heights: -999 is a reading like -998 and -1000, even twice in a row."""
    n = 3000
    z_um = np.round(texture(n, seed=9) * 1e3 / 3).astype(int) - 700   # heights around -999 often
    z_um[[200, 201, 900, 901, 1500]] = -999
    path = tmp_path / "integers.csv"
    path.write_text("distance (mm),height (um)\n" + rows(np.arange(n) * DX_MM, z_um))
    assert np.count_nonzero(z_um == -999) >= 5
    profile = read(path)
    assert not np.isnan(profile.heights).any()
    np.testing.assert_allclose(profile.heights, z_um * 1e-6, atol=1e-12)


def test_the_manifest_column_dropout_value_reaches_the_reader(tmp_path: Path) -> None:
    road = roadtex.synthetic_pavement("dense_asphalt", 0.6, 0.5e-3, seed=2)
    z = road.heights * 1e3
    cells = [f"{v:.4f}" for v in z]
    for i in (100, 101, 102, 700, 701, 702, 703):
        cells[i] = "-123"
    (tmp_path / "a.csv").write_text("distance (mm),height (mm)\n" + rows(road.positions * 1e3, cells))
    pl.DataFrame({"path": ["a.csv"], "dropout_value": [-123.0]}).write_csv(tmp_path / "manifest.csv")
    options = roadtex.ProcessingOptions(youngs_moduli=(2e6,), segment_length=0.25, error_budget_db=None)
    summary = roadtex.process(tmp_path / "manifest.csv", tmp_path / "out", options, quiet=True)
    assert summary.failed_on_record == 0
    run = pl.read_parquet(tmp_path / "out" / "runs.parquet").row(0, named=True)
    assert run["dropout_fraction"] == pytest.approx(7 / z.size, rel=0.05)
    # the command line's default for every run: --dropout-value
    from roadtex.cli import main
    pl.DataFrame({"path": ["a.csv"]}).write_csv(tmp_path / "plain.csv")
    assert main(["process", str(tmp_path / "plain.csv"), "--out", str(tmp_path / "cli"), "--moduli", "2",
                 "--segment-length", "0.25", "--error-budget", "off", "--dropout-value", "-123", "--quiet"]) == 0
    run = pl.read_parquet(tmp_path / "cli" / "runs.parquet").row(0, named=True)
    assert run["dropout_fraction"] == pytest.approx(7 / z.size, rel=0.05)


# 3. Decimal commas in a comma-delimited file without a header

def test_decimal_commas_with_a_comma_delimiter_are_refused_naming_the_line(tmp_path: Path) -> None:
    z = texture(400)
    z[5] = 2.0   # an integer height: a row of two fields
    path = tmp_path / "broken.csv"
    path.write_text("".join(f"{i},{v:.3f}\n".replace(".", ",").replace(",000\n", "\n") for i, v in enumerate(z)))
    assert path.read_text().splitlines()[5] == "5,2"
    with pytest.raises(ProfileFormatError, match=r"broken\.csv: line 6 \('5,2'\) has 2 fields where the first row "
                                                 r"has 3.*decimal commas"):
        read(path, distance_unit="mm", height_unit="mm")
    path.write_text("".join(f"{i},{v:.3f}\n".replace(".", ",") for i, v in enumerate(texture(400) + 3)))
    with pytest.raises(ProfileFormatError, match=r"broken\.csv: line 1 \('0,.*\) has 3 numbers and the file no "
                                                 r"header.*distance_column and height_column.*decimal commas"):
        read(path, distance_unit="mm", height_unit="mm")


def test_three_columns_without_a_header_are_read_when_named(tmp_path: Path) -> None:
    z = texture(300)
    path = tmp_path / "points.csv"
    path.write_text("".join(f"{i + 1},{i * DX_MM:.3f},{v:.3f}\n" for i, v in enumerate(z)))
    profile = read(path, distance_column=1, height_column=2, distance_unit="mm", height_unit="mm")
    np.testing.assert_allclose(profile.heights, z * 1e-3, atol=1e-12)
    assert profile.dx == pytest.approx(0.5e-3)


# 4. Empty cells at the ends of heights-only files

@pytest.mark.parametrize("header", ["height (mm)\n", ""], ids=["header", "no-header"])
def test_empty_cells_at_the_ends_of_heights_only_files_shift_no_position(tmp_path: Path, header: str) -> None:
    z = texture(500)
    path = tmp_path / "heights.csv"
    path.write_text(header + "\n" * 10 + "".join(f"{v:.3f}\n" for v in z) + "\n" * 40)
    profile = read(path, dx=0.5e-3, height_unit="mm")
    assert profile.positions.size == 510
    assert np.isnan(profile.heights[:10]).all()
    np.testing.assert_allclose(profile.heights[10:], z * 1e-3, atol=1e-12)
    np.testing.assert_allclose(profile.positions[10:], (10 + np.arange(500)) * 0.5e-3, atol=1e-12)
    assert any("40 empty line(s) after the last height trimmed" in line for line in profile.history)


# 5. Units stated in the file's metadata lines

@pytest.mark.parametrize("block", ["# distance_unit: mm\n# height_unit: mm\n", "Device: LS-40\nUnits: mm\n\n",
                                   "Unit = mm\n"], ids=["comments", "preamble", "equals"])
def test_units_stated_in_metadata_lines_are_the_files_units(tmp_path: Path, block: str) -> None:
    x, z = np.arange(400) * DX_MM, texture(400)
    path = tmp_path / "units.csv"
    path.write_text(block + "distance,height\n" + rows(x, z))
    profile = read(path)
    np.testing.assert_allclose(profile.positions, x * 1e-3, atol=1e-12)
    np.testing.assert_allclose(profile.heights, z * 1e-3, atol=1e-12)
    assert profile.metadata["distance_unit_stated"].startswith("mm (the file's line")
    assert any("unit mm from the file's line" in line for line in profile.history)


def test_a_units_line_that_states_no_one_unit_is_quoted_in_the_refusal(tmp_path: Path) -> None:
    path = tmp_path / "mixed.csv"
    path.write_text("Units: mm / um\ndistance,height\n" + rows(np.arange(50) * DX_MM, texture(50)))
    with pytest.raises(ProfileFormatError, match=r"mixed\.csv: no unit .*\(the file's line\(s\) 'units: mm / um' "
                                                 r"state no one unit per column\)") as refused:
        read(path)
    assert "states none" not in str(refused.value)


# 6. Thousands separators, a row with one field too many

def test_a_thousands_separator_in_a_decimal_comma_file_is_named(tmp_path: Path) -> None:
    path = tmp_path / "thousands.csv"
    path.write_text("Distance [mm];Height [mm]\n" + "".join(
        f"1.{i:03d};" + f"{v:.3f}".replace(".", ",") + "\n" for i, v in enumerate(texture(300))))
    with pytest.raises(ProfileFormatError, match=r"thousands\.csv: '1\.000' in a file with decimal commas: a "
                                                 r"thousands separator"):
        read(path)


def test_a_row_with_an_extra_number_is_refused_naming_its_line(tmp_path: Path) -> None:
    text = "distance (mm),height (mm)\n" + rows(np.arange(300) * DX_MM, texture(300))
    lines = text.splitlines()
    lines[120] += ",7.5"
    path = tmp_path / "extra.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ProfileFormatError, match=r"extra\.csv: .*line 121 is not a row of 2 numbers"):
        read(path)


def test_a_semicolon_manifest_with_a_decimal_comma_dropout_value(tmp_path: Path) -> None:
    """A European manifest writes the drop-out code as it writes every number: -99,9."""
    from roadtex.archive.manifest import read_manifest
    (tmp_path / "a.csv").write_text("distance (mm);height (mm)\n0;1\n")
    (tmp_path / "manifest.csv").write_text("path;dropout_value;speed_kmh\na.csv;-99,9;80\n")
    runs = read_manifest(tmp_path / "manifest.csv")
    rows = runs.to_dicts() if hasattr(runs, "to_dicts") else runs
    assert rows[0]["dropout_value"] == pytest.approx(-99.9)
