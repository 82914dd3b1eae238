"""Profile files as colleagues send them (the README walk): a metadata block before the table,
Excel's exports, blank lines, cells that are not numbers, units missing or wrong. Each is read to
the numbers written, or refused (or warned about) naming the file and the problem."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex.errors import CoarseSamplingWarning, ImplausibleTextureWarning, ProfileFormatError
from roadtex.profiles.plausibility import PLAUSIBLE_MAX_DX, PLAUSIBLE_MIN_RMS

N = 400
DX_MM = 0.5


def written(n: int = N) -> tuple[np.ndarray, np.ndarray]:
    """Distances and heights (mm) as a colleague's file holds them: a 2 mm-amplitude texture."""
    x = np.arange(n) * DX_MM
    z = np.round(2.0 * np.sin(2 * np.pi * x / 7.3) + 0.7 * np.cos(2 * np.pi * x / 2.9), 3)
    return x, z


def table(x: np.ndarray, z: np.ndarray, separator: str = ";", comma: bool = True) -> str:
    rows = [f"{a:.3f}{separator}{b:.3f}" for a, b in zip(x, z)]
    return "".join((r.replace(".", ",") if comma else r) + "\n" for r in rows)


def read_quietly(path: Path, **options: object) -> roadtex.Profile:
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleTextureWarning)
        return roadtex.read_profile(path, **options)


def assert_written(profile: roadtex.Profile, x: np.ndarray, z: np.ndarray) -> None:
    np.testing.assert_allclose(profile.positions, x * 1e-3, rtol=0, atol=1e-12)
    np.testing.assert_allclose(profile.heights, z * 1e-3, rtol=0, atol=1e-12)


@pytest.mark.parametrize("block", [
    "Site: A1 km 12\nOperator: J. Smith\nDate: 2024-05-01\n\n",
    "Site;A1 km 12\nOperator;J. Smith;\nDate;2024-05-01\n",
    "Site\tA1 km 12\nOperator\tJ. Smith\nDate = 2024-05-01\n",
], ids=["colon", "semicolon", "tab-and-equals"])
def test_a_metadata_block_before_the_header_is_metadata(tmp_path: Path, block: str) -> None:
    x, z = written()
    path = tmp_path / "survey.csv"
    path.write_bytes(("\ufeff" + block + "Distance (mm);Height (mm)\n" + table(x, z)).replace("\n", "\r\n").encode())
    profile = read_quietly(path)
    assert_written(profile, x, z)
    assert (profile.metadata["site"], profile.metadata["operator"], profile.metadata["date"]) == \
        ("A1 km 12", "J. Smith", "2024-05-01")


def test_excel_sep_line_quoted_names_and_trailing_empty_rows(tmp_path: Path) -> None:
    x, z = written()
    path = tmp_path / "excel.csv"
    text = 'sep=;\n"Distance (mm)";"Height (mm)"\n' + table(x, z) + ";\n;\n\n\n"
    path.write_bytes(text.replace("\n", "\r\n").encode())
    assert_written(read_quietly(path), x, z)


def test_blank_lines_inside_a_table_with_distances_are_no_rows(tmp_path: Path) -> None:
    x, z = written()
    lines = table(x, z, ",", comma=False).splitlines(keepends=True)
    lines[100:100] = ["\n", "\n"]
    path = tmp_path / "gaps.csv"
    path.write_text("distance [mm],height [mm]\n" + "".join(lines) + "\n\n")
    assert_written(read_quietly(path), x, z)


def test_heights_only_an_empty_line_is_a_dropout_and_trailing_lines_are_not_rows(tmp_path: Path) -> None:
    _, z = written()
    cells = [f"{v:.3f}" for v in z]
    cells[50] = ""
    path = tmp_path / "heights.txt"
    path.write_text("height (mm)\n" + "\n".join(cells) + "\n\n\n")
    profile = read_quietly(path, dx=DX_MM * 1e-3)
    assert profile.heights.size == N and np.isnan(profile.heights[50])
    keep = np.arange(N) != 50
    np.testing.assert_allclose(profile.heights[keep], z[keep] * 1e-3, rtol=0, atol=1e-12)


def test_a_cell_that_is_not_a_number_is_refused_naming_its_line(tmp_path: Path) -> None:
    x, z = written()
    lines = table(x, z, ",", comma=False).splitlines(keepends=True)
    lines[200] = "#N/A,sensor fault\n"
    path = tmp_path / "fault.csv"
    path.write_text("# exported 2024-05-01\ndistance (mm),height (mm)\n" + "".join(lines))
    # comment line 1, header line 2, data from line 3: row 200 (0-based) is line 203
    with pytest.raises(ProfileFormatError, match=r"fault\.csv: .*line 203 is not a row of 2 numbers: '#N/A,sensor fault'"):
        roadtex.read_profile(path)


def test_missing_units_are_all_named_with_where_to_give_them(tmp_path: Path) -> None:
    x, z = written()
    path = tmp_path / "bare.csv"
    path.write_text("distance;height\n" + table(x, z))
    with pytest.raises(ProfileFormatError, match=r"bare\.csv: no unit for the height column 'height' and the distance "
                       r"column 'distance'.*height_unit and distance_unit.*manifest column.*--height-unit, --distance-unit"):
        roadtex.read_profile(path)
    assert_written(read_quietly(path, height_unit="mm", distance_unit="mm"), x, z)


def test_unit_mistakes_in_a_file_are_warned_about_by_the_reader(tmp_path: Path) -> None:
    x, z = written()
    path = tmp_path / "bare.csv"
    path.write_text("distance;height\n" + table(x, z))
    # heights in mm said to be micrometres: 1000 times too small for any road
    with pytest.warns(ImplausibleTextureWarning, match=r"bare\.csv: rms height .* implausibly small.*millimetres read as micrometres"):
        roadtex.read_profile(path, height_unit="um", distance_unit="mm")
    # distances in mm said to be metres: a 0.5 m sampling interval, read as stated (a unit given is
    # certain: issue 34), but not a texture interval
    with pytest.warns(CoarseSamplingWarning, match=r"bare\.csv: sampled every 500 mm.*unit is m \(given for the "
                      r"file\).*resolves no texture wavelength.*were its distances in millimetres\?"):
        roadtex.read_profile(path, height_unit="mm", distance_unit="m")
    # the same without a unit: a .npy's metres are assumed, and the reader asks
    np.save(tmp_path / "bare.npy", np.column_stack([x, z * 1e-3]))
    with pytest.warns(ImplausibleTextureWarning, match=r"bare\.npy: a sampling interval of 0\.5 m is implausibly coarse"
                      r".*were they given in millimetres\?"):
        roadtex.read_profile(tmp_path / "bare.npy")


def test_the_file_limits_leave_model_problems_to_the_solvers() -> None:
    """A 1 um sinusoid on a 10 mm grid is a fine model problem for contact: no warning there (the
    file limits are for measured road profiles only), though it is beyond both of them."""
    x = np.arange(64) * 10e-3
    heights = 1e-6 * np.sin(2 * np.pi * x / 0.32)
    assert heights.std() < PLAUSIBLE_MIN_RMS and 10e-3 > PLAUSIBLE_MAX_DX
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleTextureWarning)
        r = roadtex.contact(heights, 10e-3, youngs_modulus=2e6, mean_pressure=2e5)
    assert r.converged


def test_the_job_refuses_a_unit_mistake_and_processes_the_rest(tmp_path: Path) -> None:
    survey = tmp_path / "survey"
    survey.mkdir()
    road = roadtex.synthetic_pavement("dense_asphalt", length=0.6, dx=0.5e-3, seed=2)
    millimetres = table(road.positions * 1e3, road.heights * 1e3, ",", comma=False)
    (survey / "good.csv").write_text("distance (mm),height (mm)\n" + millimetres)
    (survey / "said_metres.csv").write_text("distance,height (mm)\n" + millimetres)
    (survey / "said_micrometres.csv").write_text("distance (mm),height\n" + millimetres)
    manifest = roadtex.build_manifest(survey).with_columns(
        pl.when(pl.col("run_id") == "said_metres").then(pl.lit("m")).otherwise(None).alias("distance_unit"),
        pl.when(pl.col("run_id") == "said_micrometres").then(pl.lit("um")).otherwise(None).alias("height_unit"))
    options = roadtex.ProcessingOptions(youngs_moduli=(2e6,), error_budget_db=None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImplausibleTextureWarning)
        roadtex.process(manifest, tmp_path / "results", options)
    errors = pl.read_parquet(tmp_path / "results" / "errors.parquet").sort("run_id")
    assert errors["run_id"].to_list() == ["said_metres", "said_micrometres"]
    assert errors["stage"].to_list() == ["read", "read"]
    # a unit given is certain (issue 34), but 0.5 m resolves no band of the job's 0.5 m segments
    assert "said_metres.csv: sampled every 0.5 m (its distances' unit: m (given for the file)), which resolves no" in errors["message"][0]
    assert "Were its distances in millimetres?" in errors["message"][0]
    assert "said_micrometres.csv: rms height" in errors["message"][1] and "implausibly small" in errors["message"][1]
    runs = pl.read_parquet(tmp_path / "results" / "runs.parquet")
    assert runs["run_id"].to_list() == ["good"] and runs["dx_used"][0] == pytest.approx(0.5e-3)


def test_the_manifest_names_the_format_each_file_was_read_as(tmp_path: Path, captif_dir: Path) -> None:
    """runs.parquet's ``format`` is the manifest's: ``roadtex manifest`` fills it with the format read,
    not the metadata's (a CAPTIF profile written to Parquet keeps ``format: captif`` in it)."""
    survey = tmp_path / "survey"
    survey.mkdir()
    station = captif_dir / "20211011_aylesbury_dec_station_0.dat"
    (survey / "a_station.dat").write_bytes(station.read_bytes())
    profile = roadtex.read_profile(station)
    roadtex.write_profile(profile, survey / "b_station.parquet")
    x, z = written()
    (survey / "c_colleague.csv").write_text("Distance (mm);Height (mm)\n" + table(x, z))
    (survey / "d_junk.csv").write_bytes(bytes(range(256)) * 4)
    manifest = roadtex.build_manifest(survey)
    assert manifest["format"].to_list() == ["captif", "parquet", "csv", None]
    assert roadtex.read_profile(survey / "b_station.parquet").metadata["format"] == "captif"


def test_a_coarser_file_among_finer_runs_is_solved_on_its_own_readings(tmp_path: Path,
                                                                      capsys: pytest.CaptureFixture) -> None:
    """A colleague's file at 1 mm among 0.25 mm runs is solved on its own readings (never upsampled
    to the finer runs' interval, which made its contact that of straight chords between readings),
    and gets the tables it gets alone; ``--dx`` at its interval averages the fine file down to it,
    and the two files of one road then agree."""
    from roadtex.cli import main

    road = roadtex.synthetic_pavement("dense_asphalt", length=1.0, dx=0.25e-3, seed=4)
    survey = tmp_path / "survey"
    survey.mkdir()
    fine = table(road.positions * 1e3, road.heights * 1e3, ",", comma=False)
    (survey / "fine.csv").write_text("distance (mm),height (mm)\n" + fine)
    n = road.heights.size // 4 * 4
    blocks = road.heights[:n].reshape(-1, 4).mean(axis=1)     # what a 1 mm profilometer averages
    coarse = table(road.positions[:n:4] * 1e3, blocks * 1e3, ",", comma=False)
    (survey / "coarse.csv").write_text("distance (mm),height (mm)\n" + coarse)
    assert main(["manifest", str(survey), "--out", str(tmp_path / "manifest.csv")]) == 0

    def contact(manifest: Path, out: str, *extra: str) -> pl.DataFrame:
        capsys.readouterr()
        code = main(["process", str(manifest), "--out", str(tmp_path / out), "--moduli", "2",
                     "--error-budget", "off", "--quiet", *extra])
        assert code == 0
        said = capsys.readouterr()
        # the tables it lists are aligned in one column, surface_examples included
        listed = [line for line in said.out.splitlines() if line.startswith("  ")]
        assert len(listed) >= 8 and len({line.index(str(tmp_path)) for line in listed}) == 1, said.out
        return pl.read_parquet(tmp_path / out / "segments.parquet")

    together = contact(tmp_path / "manifest.csv", "both")
    runs = pl.read_parquet(tmp_path / "both" / "runs.parquet")
    assert dict(runs.select("run_id", "dx_used").iter_rows()) == pytest.approx({"fine": 0.25e-3, "coarse": 1e-3})
    manifest = pl.read_csv(tmp_path / "manifest.csv")
    manifest.filter(pl.col("run_id") == "coarse").write_csv(tmp_path / "coarse_only.csv")
    alone = contact(tmp_path / "coarse_only.csv", "alone")
    assert together.filter(pl.col("run_id") == "coarse").equals(alone)
    same_grid = contact(tmp_path / "manifest.csv", "coarsest", "--dx", "1e-3")
    means = dict(same_grid.group_by("run_id").agg(pl.col("contact_fraction").mean()).iter_rows())
    assert abs(means["coarse"] - means["fine"]) < 0.01, means


def test_roadtex_manifest_names_the_files_it_cannot_read_and_why(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from roadtex.cli import main

    x, z = written()
    (tmp_path / "good.csv").write_text("distance (mm);height (mm)\n" + table(x, z))
    (tmp_path / "bare.csv").write_text("distance;height\n" + table(x, z))
    (tmp_path / "empty.csv").write_bytes(b"")
    (tmp_path / "junk.csv").write_bytes(bytes(range(256)) * 4)
    assert main(["manifest", str(tmp_path), "--out", str(tmp_path / "manifest.csv")]) == 0
    said = capsys.readouterr().err
    assert "3 of the files cannot be read" in said and "good.csv" not in said
    assert "empty.csv is empty" in said and "junk.csv looks like binary data" in said
    assert "bare.csv: no unit for the height column 'height' and the distance column 'distance'" in said
    assert pl.read_csv(tmp_path / "manifest.csv").height == 4     # listed all the same


@pytest.mark.parametrize("header", ["Distance;Height\nmm;mm\n", "Site: A1\n\n\"Distance\";\"Height\"\n[mm];[mm]\n",
                                    "Distance;Height\n(mm);(mm)\n"], ids=["bare", "after-metadata", "parenthesised"])
def test_two_header_rows_names_then_units(tmp_path: Path, header: str) -> None:
    x, z = written()
    path = tmp_path / "two.csv"
    path.write_text(header + table(x, z))
    assert_written(read_quietly(path), x, z)


def test_heights_only_without_dx_says_where_to_give_it(tmp_path: Path) -> None:
    _, z = written()
    np.save(tmp_path / "dump.npy", z * 1e-3)
    with pytest.raises(ProfileFormatError, match=r"dump\.npy: heights only .*manifest column dx or roadtex process --input-dx"):
        roadtex.read_profile(tmp_path / "dump.npy")


def test_a_given_unit_fills_in_and_never_rescales_a_header_unit(tmp_path: Path, captif_dir: Path) -> None:
    """--height-unit (a job's reader default) is for files whose header states no unit: a file whose
    header says um keeps um, with a warning, and gives the same road as its headerless mm twin."""
    from roadtex.errors import UnitConflictWarning

    x, z = written()
    micrometres = tmp_path / "um.csv"
    micrometres.write_text("distance (mm);height (um)\n" + "".join(f"{a:.3f};{b * 1e3:.0f}\n" for a, b in zip(x, z)))
    with pytest.warns(UnitConflictWarning, match=r"um\.csv: the height column 'height \(um\)' states its unit, um; "
                                                  r"the height_unit 'mm' given is ignored") as caught:
        profile = roadtex.read_profile(micrometres, height_unit="mm")
    assert_written(profile, x, z)
    assert caught[0].filename == __file__    # the warning points at the read_profile call
    # CAPTIF files state mm: a job-wide um does not rescale them either
    station = captif_dir / "20211011_aylesbury_dec_station_0.dat"
    rows = station.read_text().split("*****DATA*****", 1)[1].splitlines()[2:7]
    first_heights = [float(r.split("\t")[2]) * 1e-3 for r in rows]
    with pytest.warns(UnitConflictWarning, match="20211011_aylesbury_dec_station_0.dat: the height column 'Depth"):
        captif = roadtex.read_profile(station, height_unit="um")
    np.testing.assert_allclose(captif.heights[:5], first_heights, rtol=0, atol=1e-15)

    survey = tmp_path / "survey"
    survey.mkdir()
    road = roadtex.synthetic_pavement("dense_asphalt", length=0.6, dx=0.5e-3, seed=5)
    mm = np.round(road.heights * 1e3, 3)
    (survey / "bare.csv").write_text("".join(f"{a * 1e3:.3f},{b:.3f}\n" for a, b in zip(road.positions, mm)))
    (survey / "stated.csv").write_text("distance (mm),height (um)\n" +
                                       "".join(f"{a * 1e3:.3f},{b * 1e3:.0f}\n" for a, b in zip(road.positions, mm)))
    options = roadtex.ProcessingOptions(youngs_moduli=(2e6,), error_budget_db=None,
                                        reader_defaults={"distance_unit": "mm", "height_unit": "mm"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnitConflictWarning)
        roadtex.process(roadtex.build_manifest(survey), tmp_path / "results", options)
    runs = pl.read_parquet(tmp_path / "results" / "runs.parquet").sort("run_id")
    assert runs["run_id"].to_list() == ["bare", "stated"]
    assert runs["mpd"][1] == pytest.approx(runs["mpd"][0], rel=1e-9) and 0.2e-3 < runs["mpd"][0] < 3e-3


def test_a_decimal_comma_forced_on_a_comma_separated_file_says_where_to_give_the_delimiter(tmp_path: Path) -> None:
    x, z = written()
    path = tmp_path / "points.csv"
    path.write_text("distance (mm),height (mm)\n" + table(x, z, ",", comma=False))
    with pytest.raises(ProfileFormatError, match=r"points\.csv: a comma cannot be both .*roadtex process --delimiter"):
        roadtex.read_profile(path, decimal=",")


def test_a_file_with_numeric_dropout_codes_is_processed_and_its_codes_counted(tmp_path: Path) -> None:
    """A profilometer writes -9999 (mm) where it had no reading. The run must not be refused as a
    unit mistake, its codes must be counted as outliers, and its MPD must be that of the road."""
    road = roadtex.synthetic_pavement("dense_asphalt", 0.6, 0.5e-3, seed=2)
    x_mm, z_mm = road.positions * 1e3, road.heights * 1e3
    coded = z_mm.copy()
    coded[[150, 420, 777, 1010]] = -9999.0
    for name, heights in (("clean.csv", z_mm), ("coded.csv", coded)):
        (tmp_path / name).write_text("distance (mm);height (mm)\n" + table(x_mm, heights, comma=False))
    manifest = tmp_path / "manifest.csv"
    pl.DataFrame({"path": ["clean.csv", "coded.csv"]}).write_csv(manifest)
    options = roadtex.ProcessingOptions(youngs_moduli=(2e6,), segment_length=0.25, error_budget_db=None)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleTextureWarning)
        summary = roadtex.process(manifest, tmp_path / "out", options, quiet=True)
    assert summary.failed_on_record == 0, pl.read_parquet(tmp_path / "out" / "errors.parquet")
    runs = pl.read_parquet(tmp_path / "out" / "runs.parquet").sort("path")
    clean, coded_run = runs.row(0, named=True), runs.row(1, named=True)
    assert coded_run["outlier_fraction"] == pytest.approx(4 / road.heights.size)
    assert coded_run["mpd"] == pytest.approx(clean["mpd"], rel=0.02)
