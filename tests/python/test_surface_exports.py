"""3-D texture surfaces exported the way colleagues send them (long tables with units in the header
or not, `;` with decimal commas, a byte-order mark and Windows line ends, rounded positions, grids
of heights as text, transposed files), through the readers and the README's bulk-job commands."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from exports import readme_bulk_commands
from roadtex.errors import InvalidInputError, ProfileFormatError
from roadtex.profiles.readers import read_profile
from roadtex.surfaces import synthetic_surface
from roadtex.surfaces.readers import is_surface_file, read_surface

ROADTEX = Path(sys.executable).parent / "roadtex"
README = Path(__file__).resolve().parents[2] / "README.md"


def long_lines(z: np.ndarray, dx_mm: float, dy_mm: float, *, sep: str = ",", decimal: str = ".",
               digits: int = 4, tokens: dict[tuple[int, int], str] | None = None) -> list[str]:
    """Rows ``x, y, z`` (mm) of heights ``z[iy, ix]`` (m), x varying fastest, as lab software writes them."""
    rows = []
    for iy in range(z.shape[0]):
        for ix in range(z.shape[1]):
            cells = [f"{ix * dx_mm:.{digits}f}", f"{iy * dy_mm:.{digits}f}", f"{z[iy, ix] * 1e3:.{digits}f}"]
            if tokens and (iy, ix) in tokens:
                cells[2] = tokens[(iy, ix)]
            rows.append(sep.join(c.replace(".", ",") if decimal == "," else c for c in cells))
    return rows


@pytest.fixture(scope="module")
def surface() -> np.ndarray:
    return synthetic_surface("dense_asphalt", 0.1, 0.01, 0.5e-3, seed=11).heights   # (20, 200), m


def test_semicolon_decimal_comma_bom_and_crlf_read_as_the_plain_csv(tmp_path: Path, surface: np.ndarray) -> None:
    header = ["x [mm]", "y [mm]", "z [mm]"]
    (tmp_path / "plain.csv").write_text("\n".join([",".join(header), *long_lines(surface, 0.5, 0.5)]) + "\n")
    text = "\r\n".join([";".join(header), *long_lines(surface, 0.5, 0.5, sep=";", decimal=",")]) + "\r\n"
    (tmp_path / "european.csv").write_bytes(b"\xef\xbb\xbf" + text.encode())
    for name in ("plain.csv", "european.csv"):
        s = read_surface(tmp_path / name)
        assert s.shape == surface.shape and s.dx == pytest.approx(0.5e-3, rel=1e-12)
        np.testing.assert_allclose(s.heights, surface, rtol=0, atol=0.5e-7)   # written to 0.1 um


def test_rounded_positions_give_the_grid_and_its_spacing(tmp_path: Path, surface: np.ndarray) -> None:
    """CAPTIF-like 0.037489 mm steps written to 0.001 mm: positions up to 1.3 % of a step off the grid."""
    dx_mm = 0.037489
    lines = ["x (mm),y (mm),z (mm)", *long_lines(surface, dx_mm, 1.0, digits=3)]
    (tmp_path / "rounded.csv").write_text("\n".join(lines) + "\n")
    s = read_surface(tmp_path / "rounded.csv")
    assert s.shape == surface.shape and s.dy == pytest.approx(1e-3, rel=1e-12)
    # the span (rounded to 0.5 um) over 199 steps
    assert s.dx == pytest.approx(dx_mm * 1e-3, abs=0.0005e-3 / 199)
    np.testing.assert_allclose(s.heights, surface, rtol=0, atol=0.5e-6)
    # a position a third of a step off is still no grid
    lines[5] = lines[5].replace(lines[5].split(",")[0], f"{4.33 * dx_mm:.3f}", 1)
    (tmp_path / "off.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(ProfileFormatError, match=r"off\.csv: not a regular grid"):
        read_surface(tmp_path / "off.csv")


def test_headerless_table_is_x_y_z_and_missing_units_are_named_together(tmp_path: Path, surface: np.ndarray) -> None:
    (tmp_path / "bare.csv").write_text("\n".join(long_lines(surface, 0.5, 0.5)) + "\n")
    with pytest.raises(ProfileFormatError, match=r"bare\.csv: no unit for the distance columns 'column_1', "
                                                 r"'column_2' and the height column 'column_3'"):
        read_surface(tmp_path / "bare.csv")
    s = read_surface(tmp_path / "bare.csv", distance_unit="mm", height_unit="mm")
    np.testing.assert_allclose(s.heights, surface, rtol=0, atol=0.5e-7)
    (tmp_path / "nounit.csv").write_text("\n".join(["x,y,z", *long_lines(surface, 0.5, 0.5)]) + "\n")
    with pytest.raises(ProfileFormatError, match=r"distance columns 'x', 'y' and the height column 'z'.*"
                                                 r"--distance-unit, --height-unit"):
        read_surface(tmp_path / "nounit.csv")


def test_dropout_tokens_are_dropouts_and_a_word_is_named(tmp_path: Path, surface: np.ndarray) -> None:
    tokens = {(0, 3): "NaN", (1, 4): "-", (2, 5): "NA", (3, 6): "", (4, 7): "null"}
    (tmp_path / "gaps.csv").write_text("\n".join(["x (mm),y (mm),z (mm)", *long_lines(surface, 0.5, 0.5,
                                                                                      tokens=tokens)]) + "\n")
    s = read_surface(tmp_path / "gaps.csv")
    assert sorted(zip(*np.nonzero(np.isnan(s.heights)))) == sorted(tokens)
    tokens[(5, 8)] = "oops"
    (tmp_path / "word.csv").write_text("\n".join(["x (mm),y (mm),z (mm)", *long_lines(surface, 0.5, 0.5,
                                                                                      tokens=tokens)]) + "\n")
    with pytest.raises(ProfileFormatError, match=r"word\.csv: column 'z \(mm\)' is .*not numeric.*'oops'"):
        read_surface(tmp_path / "word.csv")


def test_a_grid_of_heights_as_text_is_refused_as_profile_and_as_surface(tmp_path: Path, surface: np.ndarray) -> None:
    """One line per row across the road: never read as a profile of its first two columns."""
    for name, header in (("grid.csv", None), ("positions.csv", ",".join(f"{0.5 * i:.1f}" for i in range(200)))):
        lines = [",".join(f"{v * 1e3:.4f}" for v in row) for row in surface]
        (tmp_path / name).write_text("\n".join(([header] if header else []) + lines) + "\n")
        for read in (read_profile, read_surface):
            with pytest.raises(ProfileFormatError, match=rf"{name.replace('.', '[.]')}: .*grid of heights") as caught:
                read(tmp_path / name, distance_unit="mm", height_unit="mm")
            assert len(str(caught.value)) < 600      # no list of 200 column names
    # a table with x, y, z and extra columns is still a long table
    extra = {f"quality_{i}": np.zeros(4) for i in range(6)}
    pl.DataFrame({"x_mm": [0.0, 1.0, 0.0, 1.0], "y_mm": [0.0, 0.0, 1.0, 1.0], "z_mm": np.ones(4), **extra}
                 ).write_csv(tmp_path / "extra.csv")
    assert read_surface(tmp_path / "extra.csv").shape == (2, 2)


def test_a_transposed_or_short_surface_says_why_its_tiles_do_not_fit(surface: np.ndarray) -> None:
    s = synthetic_surface("dense_asphalt", 0.1, 0.01, 0.5e-3, seed=11)
    with pytest.raises(InvalidInputError, match="exceeds the surface.*shorter tiles.*--segment-length"):
        s.tiles(0.5, s.width)
    from roadtex.surfaces.surface import Surface
    flipped = Surface(s.heights.T.copy(), s.dx, s.dy)
    with pytest.raises(InvalidInputError, match=r"wider across the road \(200 rows\).*transposed"):
        flipped.tiles(0.05, flipped.width)


def test_surface_files_are_told_from_profiles(tmp_path: Path, surface: np.ndarray, captif_dir: Path) -> None:
    np.save(tmp_path / "grid.npy", surface)
    np.save(tmp_path / "pairs.npy", np.column_stack([np.arange(10.0), np.zeros(10)]))
    np.save(tmp_path / "heights.npy", np.zeros(10))
    pl.DataFrame({"x (m)": [0.0, 1e-3], "y (m)": [0.0, 0.0], "z (m)": [0.0, 1e-4]}).write_parquet(tmp_path / "s.parquet")
    pl.DataFrame({"distance (m)": [0.0, 1e-3], "height (m)": [0.0, 1e-4]}).write_parquet(tmp_path / "p.parquet")
    (tmp_path / "profile.csv").write_text("distance (mm);height (mm)\n0;1\n0,5;2\n")
    (tmp_path / "lateral.tsv").write_text("\ufeff# site: A1\nPosition (mm)\tLateral (mm)\tHeight (um)\n0\t0\t1\n")
    expected = {"grid.npy": True, "pairs.npy": False, "heights.npy": False, "s.parquet": True, "p.parquet": False,
                "profile.csv": False, "lateral.tsv": True}
    assert {name: is_surface_file(tmp_path / name) for name in expected} == expected
    assert not any(is_surface_file(p) for p in captif_dir.glob("*.dat"))


def test_readme_commands_on_a_folder_of_surfaces_profiles_and_a_broken_file(tmp_path: Path) -> None:
    """`roadtex manifest` marks the surfaces itself; the job solves them with both models, solves the
    profile, records the broken file by name and goes on; the report is drawn."""
    survey = tmp_path / "survey"
    survey.mkdir()
    lab = synthetic_surface("dense_asphalt", 0.5, 0.01, 1e-3, seed=2).heights
    (survey / "lab_scan.csv").write_text("\n".join([";".join(["x [mm]", "y [mm]", "z [mm]"]),
                                                    *long_lines(lab, 1.0, 1.0, sep=";", decimal=",")]) + "\n")
    np.save(survey / "scanner.npy", synthetic_surface("porous_asphalt", 0.5, 0.01, 1e-3, seed=3).heights)
    (survey / "scanner.npy.json").write_text(json.dumps({"dx": 1e-3, "dy": 1e-3}))
    np.save(survey / "no_spacing.npy", lab)
    line = synthetic_surface("dense_asphalt", 1.0, 0.004, 0.5e-3, seed=5).heights[0]
    (survey / "profile.csv").write_text("distance (mm),height (mm)\n"
                                        + "".join(f"{0.5 * i:.1f},{h * 1e3:.4f}\n" for i, h in enumerate(line)))
    (survey / "broken.csv").write_text("x (mm),y (mm),z (mm)\n0,0,0.1\n1,0,oops\n0,1,0.2\n1,1,0.3\n")
    commands = readme_bulk_commands(README)
    done = [subprocess.run([str(ROADTEX), *[str(survey) if a == "SURVEY_FOLDER" else a for a in argv[1:]]],
                           cwd=tmp_path, capture_output=True, text=True, timeout=900) for argv in commands]
    manifest_step, process_step, report_step = done
    assert manifest_step.returncode == 0, manifest_step.stderr
    assert "3-D surfaces" in manifest_step.stdout
    # the surfaces that cannot be read as they are, with the reason, and nothing about the others
    assert "no_spacing.npy: a .npy surface needs dx" in manifest_step.stderr
    assert "manifest columns dx and dy, or a no_spacing.npy.json sidecar" in manifest_step.stderr
    assert "broken.csv: column 'z (mm)'" in manifest_step.stderr and "lab_scan" not in manifest_step.stderr
    manifest = pl.read_csv(tmp_path / "manifest.csv")
    formats = dict(zip([Path(p).name for p in manifest["path"]], manifest["format"]))
    assert formats == {"broken.csv": "surface", "lab_scan.csv": "surface", "no_spacing.npy": "surface",
                       "profile.csv": "csv", "scanner.npy": "surface"}
    assert process_step.returncode == 1, process_step.stderr[-2000:]        # failures on record
    errors = pl.read_parquet(tmp_path / "results" / "errors.parquet")
    assert sorted(errors["run_id"]) == ["broken", "no_spacing"]
    assert all(Path(p).name in m for p, m in zip(errors["path"], errors["message"]))
    segments = pl.read_parquet(tmp_path / "results" / "segments.parquet")
    models = segments.group_by("run_id").agg(pl.col("model").unique().sort())
    assert dict(zip(models["run_id"], models["model"].to_list())) == {
        "lab_scan": ["areal", "line"], "scanner": ["areal", "line"], "profile": ["line"]}
    runs = pl.read_parquet(tmp_path / "results" / "runs.parquet")
    lab_run = runs.filter(pl.col("run_id") == "lab_scan").row(0, named=True)
    assert lab_run["file_dx"] == pytest.approx(1e-3, rel=1e-12) and lab_run["length"] == pytest.approx(0.5, rel=1e-12)
    assert report_step.returncode == 0, report_step.stderr[-2000:]


def test_a_surface_in_the_wrong_unit_warns_as_a_profile_does(tmp_path: Path, surface: np.ndarray) -> None:
    import warnings

    from roadtex.errors import ImplausibleTextureWarning

    np.save(tmp_path / "scan.npy", surface * 1e3)                     # millimetres, no unit given
    with pytest.warns(ImplausibleTextureWarning, match=r"scan\.npy \(surface row .*millimetres"):
        read_surface(tmp_path / "scan.npy", dx=0.5e-3)
    codes = {(2, 3): "-9999.0", (4, 5): "-850.0"}                    # drop-out codes are left out
    (tmp_path / "codes.csv").write_text("\n".join(["x (mm),y (mm),z (mm)", *long_lines(surface, 0.5, 0.5,
                                                                                      tokens=codes)]) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleTextureWarning)
        np.testing.assert_allclose(read_surface(tmp_path / "scan.npy", dx=0.5e-3, height_unit="mm").heights, surface)
        assert read_surface(tmp_path / "codes.csv").heights[2, 3] == pytest.approx(-9.999)


def test_blank_separated_point_lists_read_as_the_csv(tmp_path: Path, surface: np.ndarray) -> None:
    """x y z point lists as scanners write them: blanks between fields, names with units in brackets,
    padded columns, or no header at all (x, y, z in that order)."""
    spaced = [line.replace(",", "  ") for line in long_lines(surface, 0.5, 0.5)]
    (tmp_path / "named.txt").write_text("\n".join(["x (mm) y (mm) z (mm)", *spaced]) + "\n")
    (tmp_path / "padded.txt").write_text("\n".join(["   x   y   z", *[f"  {line}  " for line in spaced]]) + "\n")
    (tmp_path / "bare.txt").write_text("\n".join(spaced) + "\n")
    assert is_surface_file(tmp_path / "named.txt") and is_surface_file(tmp_path / "padded.txt")
    for name in ("named.txt", "padded.txt", "bare.txt"):
        s = read_surface(tmp_path / name, distance_unit="mm", height_unit="mm")
        assert s.shape == surface.shape and s.dx == pytest.approx(0.5e-3, rel=1e-12)
        np.testing.assert_allclose(s.heights, surface, rtol=0, atol=0.51e-7)
    (tmp_path / "mixed.txt").write_text("x_mm y_mm z_mm\n" + "\n".join(line.replace("  ", "\t", 1)
                                                                       for line in spaced) + "\n")
    with pytest.raises(ProfileFormatError, match=r"mixed\.txt: the header .* has 1 fields but the first data row "
                                                 r"has 2 .*mixes separators"):
        read_surface(tmp_path / "mixed.txt")


def test_an_xyz_point_list_saved_as_npy_is_not_read_as_a_grid(tmp_path: Path, surface: np.ndarray) -> None:
    iy, ix = np.indices(surface.shape)
    np.save(tmp_path / "points.npy", np.column_stack([ix.ravel() * 0.5e-3, iy.ravel() * 0.5e-3, surface.ravel()]))
    assert is_surface_file(tmp_path / "points.npy")                    # a surface run: it fails saying why
    with pytest.raises(ProfileFormatError, match=r"points\.npy: shape \(4000, 3\): an x, y, z point list"):
        read_surface(tmp_path / "points.npy", dx=0.5e-3)
