"""More profile exports as colleagues send them, and command-line slips (the README walk of
2026-11-23): rows dropped instead of written as drop-outs, distances rounded too coarsely, heights
only with the spacing in a header, a run shorter than a segment, gzipped files in the survey folder,
a hand-edited manifest, --dx in millimetres. Each is processed as the road it holds, with what was
missing counted, or refused naming the file, the problem and what to do."""

from __future__ import annotations

import gzip
import warnings
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex.archive.manifest import read_manifest
from roadtex.cli import main
from roadtex.errors import ManifestError, ProfileFormatError

DX_MM = 0.5


def road(length: float = 0.8, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Distances and heights (mm) of a synthetic dense asphalt at 0.5 mm."""
    profile = roadtex.synthetic_pavement("dense_asphalt", length=length, dx=DX_MM * 1e-3, seed=seed)
    return np.round(profile.positions * 1e3, 3), np.round(profile.heights * 1e3, 4)


def csv(x: np.ndarray, z: np.ndarray) -> str:
    return "distance (mm),height (mm)\n" + "".join(f"{a:.3f},{b:.4f}\n" for a, b in zip(x, z))


def removed_rows(n: int, share: float, seed: int = 0) -> np.ndarray:
    """Indices of ``share`` of the rows, the first and last kept (an export that dropped its drop-outs)."""
    rng = np.random.default_rng(seed)
    return np.sort(rng.choice(np.arange(1, n - 1), int(share * n), replace=False))


def test_rows_dropped_from_the_file_keep_its_interval_and_count_as_dropouts(tmp_path: Path) -> None:
    x, z = road()
    gone = removed_rows(x.size, 0.15)
    keep = np.setdiff1d(np.arange(x.size), gone)
    (tmp_path / "full.csv").write_text(csv(x, z))
    (tmp_path / "gaps.csv").write_text(csv(x[keep], z[keep]))
    gaps = roadtex.read_profile(tmp_path / "gaps.csv")
    # the interval is the device's, not the mean step over the gaps (which is 1 / 0.85 times longer)
    assert gaps.dx == pytest.approx(DX_MM * 1e-3, rel=1e-9)
    assert f"{gone.size} rows missing" in gaps.history[-1]
    _, summary = roadtex.profiles.conditioning.clean(gaps, trim_plates=False, spike_alpha=None, warn=False)
    assert summary.dropout_fraction == pytest.approx(gone.size / x.size, rel=1e-12)
    assert "15.0 % of the readings are drop-outs" in summary.warnings[0]
    # ISO 13473-1: a missing row is a drop-out of its baseline, as a NaN row is
    nan_rows = z.copy()
    nan_rows[gone] = np.nan
    (tmp_path / "nan_rows.csv").write_text(csv(x, nan_rows).replace("nan", ""))
    by_gaps = roadtex.mpd(gaps).segments["dropout_fraction"].to_numpy()
    by_nans = roadtex.mpd(roadtex.read_profile(tmp_path / "nan_rows.csv")).segments["dropout_fraction"].to_numpy()
    np.testing.assert_allclose(by_gaps, by_nans, rtol=0, atol=1e-12)

    manifest = pl.DataFrame({"path": [str(tmp_path / "full.csv"), str(tmp_path / "gaps.csv")]})
    options = roadtex.ProcessingOptions(youngs_moduli=(2e6,), segment_length=0.25, error_budget_db=None)
    roadtex.process(manifest, tmp_path / "out", options, quiet=True)
    runs = pl.read_parquet(tmp_path / "out" / "runs.parquet").sort("run_id")
    full, gapped = runs.row(0, named=True), runs.row(1, named=True)
    assert gapped["file_dx"] == pytest.approx(full["file_dx"], rel=1e-9) and gapped["dx_used"] == full["dx_used"]
    assert gapped["dropout_fraction"] == pytest.approx(gone.size / x.size, rel=1e-12)
    assert "drop-outs" in gapped["conditioning_warnings"]


def test_positions_rounded_to_the_sampling_are_one_interval(tmp_path: Path) -> None:
    """A 0.0375 mm device written with 3 decimals in mm (steps of 0.037 and 0.038 mm, as CAPTIF's
    files) with rows missing: the interval is still the device's to rounding, not the median step."""
    n, step = 8000, 0.0375
    x = np.round(np.arange(n) * step, 3)
    z = np.round(np.sin(2 * np.pi * x / 7.3) + 0.5 * np.cos(2 * np.pi * x / 1.9), 4)
    gone = removed_rows(n, 0.1, seed=4)
    keep = np.setdiff1d(np.arange(n), gone)
    (tmp_path / "rounded_gaps.csv").write_text(csv(x[keep], z[keep]))
    profile = roadtex.read_profile(tmp_path / "rounded_gaps.csv")
    assert profile.dx == pytest.approx(step * 1e-3, rel=2e-4)
    assert f"{gone.size} rows missing" in profile.history[-1]


def test_distances_rounded_too_coarsely_are_refused_saying_so(tmp_path: Path) -> None:
    x, z = road()
    text = "distance (mm),height (mm)\n" + "".join(f"{a:.0f},{b:.4f}\n" for a, b in zip(x, z))   # 0.5 mm -> 1 mm
    (tmp_path / "coarse_x.csv").write_text(text)
    with pytest.raises(ProfileFormatError, match=r"coarse_x\.csv: .*duplicate positions.*the distances look rounded "
                                                 r"to steps of 0\.001 m, coarser than the 0\.0005 m between readings"):
        roadtex.read_profile(tmp_path / "coarse_x.csv")


def test_heights_only_with_the_spacing_in_the_header_says_where_to_give_dx(tmp_path: Path) -> None:
    _, z = road()
    path = tmp_path / "heights.txt"
    path.write_text("# Sample spacing: 0.5 mm\nheight (mm)\n" + "".join(f"{b:.4f}\n" for b in z))
    with pytest.raises(ProfileFormatError, match=r"heights\.txt: no distance column .*manifest column dx or roadtex "
                                                 r"process --input-dx\); the file's header says 'sample_spacing: 0\.5 mm'"):
        roadtex.read_profile(path)
    np.testing.assert_allclose(roadtex.read_profile(path, dx=DX_MM * 1e-3).heights, z * 1e-3, rtol=0, atol=1e-15)


def test_a_run_shorter_than_a_segment_fails_naming_the_file_and_the_option(tmp_path: Path,
                                                                            capsys: pytest.CaptureFixture) -> None:
    x, z = road(length=0.8)
    (tmp_path / "long.csv").write_text(csv(x, z))
    short = x < 300.0
    (tmp_path / "short.csv").write_text(csv(x[short], z[short]))
    pl.DataFrame({"path": ["long.csv", "short.csv"]}).write_csv(tmp_path / "manifest.csv")
    code = main(["process", str(tmp_path / "manifest.csv"), "--out", str(tmp_path / "out"), "--moduli", "2",
                 "--error-budget", "off", "--quiet"])
    assert code == 1
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet")
    assert errors["run_id"].to_list() == ["short"] and errors["stage"].to_list() == ["segment"]
    message = errors["message"][0]
    assert message.startswith("short.csv: the run is 0.3 m long") and "--segment-length" in message, message
    assert "of at most 0.3 m" in message
    assert pl.read_parquet(tmp_path / "out" / "runs.parquet")["run_id"].to_list() == ["long"]


def test_every_recorded_failure_names_its_file(tmp_path: Path) -> None:
    """A failure after the read stage (here the MPD's: a run shorter than one 100 mm baseline) is
    recorded with the file's name too, as the readers' failures are."""
    x, z = road(length=0.8)
    (tmp_path / "long.csv").write_text(csv(x, z))
    tiny = x < 60.0
    (tmp_path / "tiny.csv").write_text(csv(x[tiny], z[tiny]))
    options = roadtex.ProcessingOptions(youngs_moduli=(2e6,), segment_length=0.05, error_budget_db=None)
    roadtex.process(read_manifest(pl.DataFrame({"path": ["long.csv", "tiny.csv"]}), base_dir=tmp_path),
                    tmp_path / "out", options, quiet=True)
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet")
    assert errors["stage"].to_list() == ["mpd"]
    assert errors["message"][0].startswith("tiny.csv: "), errors["message"][0]


def test_roadtex_manifest_says_which_files_it_does_not_list(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    x, z = road()
    survey = tmp_path / "survey"
    survey.mkdir()
    (survey / "plain.csv").write_text(csv(x, z))
    with gzip.open(survey / "packed.csv.gz", "wt") as handle:
        handle.write(csv(x, z))
    (survey / "notes.xlsx").write_bytes(b"PK\x03\x04")
    assert main(["manifest", str(survey), "--out", str(tmp_path / "manifest.csv")]) == 0
    said = capsys.readouterr()
    assert "1 runs" in said.out and pl.read_csv(tmp_path / "manifest.csv").height == 1
    assert "2 file(s) of the folder are not listed" in said.err
    assert "packed.csv.gz: compressed (.gz)" in said.err and "decompress it" in said.err
    assert "notes.xlsx: suffix '.xlsx'" in said.err
    # a folder of gzipped files alone: refused, saying what is there
    (survey / "plain.csv").unlink()
    assert main(["manifest", str(survey), "--out", str(tmp_path / "again.csv")]) == 2
    assert "not listed: notes.xlsx" in capsys.readouterr().err


def test_a_hand_edited_manifest_is_refused_with_what_was_meant(tmp_path: Path) -> None:
    x, z = road()
    data = tmp_path / "data"
    data.mkdir()
    (data / "a.csv").write_text(csv(x, z))
    kept = tmp_path / "manifests"
    kept.mkdir()
    # paths written from the current folder, the manifest kept in another
    pl.DataFrame({"path": ["data/a.csv"]}).write_csv(kept / "relative.csv")
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(tmp_path)
        with pytest.raises(ManifestError, match=r"relative paths are taken from the manifest's folder, .*manifests "
                                                r"\(data/a\.csv is a file from the current folder"):
            read_manifest(kept / "relative.csv")
    pl.DataFrame({"path": ["data/a.csv"], "hieght_unit": ["mm"]}).write_csv(tmp_path / "typo.csv")
    with pytest.raises(ManifestError, match=r"'hieght_unit': did you mean 'height_unit'\?"):
        read_manifest(tmp_path / "typo.csv")
    pl.DataFrame({"path": ["data/a.csv"], "youngs_modulus": [2e6]}).write_csv(tmp_path / "modulus.csv")
    with pytest.raises(ManifestError, match=r"'youngs_modulus' is a job option, not a manifest column: "
                                            r"roadtex process --moduli"):
        read_manifest(tmp_path / "modulus.csv")


@pytest.mark.parametrize("flag", ["--dx", "--input-dx"])
def test_an_interval_given_in_millimetres_is_refused_before_any_work(tmp_path: Path, flag: str,
                                                                    capsys: pytest.CaptureFixture) -> None:
    x, z = road()
    (tmp_path / "a.csv").write_text(csv(x, z))
    pl.DataFrame({"path": ["a.csv"]}).write_csv(tmp_path / "manifest.csv")
    code = main(["process", str(tmp_path / "manifest.csv"), "--out", str(tmp_path / "out"), flag, "0.5"])
    assert code == 2 and not (tmp_path / "out" / "runs.parquet").exists()
    assert f"{flag} 0.5 m is coarser than any texture profile's sampling" in capsys.readouterr().err
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = main(["process", str(tmp_path / "manifest.csv"), "--out", str(tmp_path / "out"), "--dx", "1e-3",
                     "--moduli", "2", "--error-budget", "off", "--quiet"])
    assert code == 0


def test_a_job_with_no_run_done_states_no_sampling_interval(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    (tmp_path / "bad.csv").write_text("distance (mm),height (mm)\n0,1\n0.5,2\nEnd of data\n")
    pl.DataFrame({"path": ["bad.csv"]}).write_csv(tmp_path / "manifest.csv")
    assert main(["process", str(tmp_path / "manifest.csv"), "--out", str(tmp_path / "out"), "--quiet"]) == 1
    said = capsys.readouterr().out
    assert "0 processed" in said and " at dx " not in said, said
    # nothing to draw: the report says why each run failed, not only that they did
    assert main(["report", str(tmp_path / "out")]) == 2
    said = capsys.readouterr().err
    assert "every run failed" in said and "bad (read): bad.csv: cannot read the numbers" in said, said


def test_the_job_refuses_a_unit_mistake_saying_what_to_correct_and_never_computing_as_given(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    x, z = road()
    (tmp_path / "good.csv").write_text(csv(x, z))
    (tmp_path / "heights.txt").write_text("height (mm)\n" + "".join(f"{b:.4f}\n" for b in z))
    # a header that states the wrong unit: heights in mm said to be metres
    (tmp_path / "said_m.csv").write_text(csv(x, z).replace("height (mm)", "height (m)"))
    assert main(["manifest", str(tmp_path), "--out", str(tmp_path / "manifest.csv")]) == 0   # prints its warnings
    said = capsys.readouterr().err
    assert "said_m.csv: peak-to-valley" in said and "roadtex process refuses it" in said, said
    assert "Computing as given" not in said
    # the colleague's dx, 0.5 (mm), written into the manifest as it was said
    table = pl.read_csv(tmp_path / "manifest.csv").with_columns(
        pl.when(pl.col("run_id") == "heights").then(0.5).otherwise(None).alias("dx"))
    table.write_csv(tmp_path / "manifest.csv")
    assert main(["process", str(tmp_path / "manifest.csv"), "--out", str(tmp_path / "out"), "--moduli", "2",
                 "--error-budget", "off", "--quiet"]) == 1
    assert "Computing as given" not in capsys.readouterr().err
    errors = dict(pl.read_parquet(tmp_path / "out" / "errors.parquet").select("run_id", "message").iter_rows())
    assert sorted(errors) == ["heights", "said_m"]
    assert "The interval dx = 0.5 given for it (manifest column dx, --input-dx) must be in metres" in errors["heights"]
    assert "a unit its header states wrongly must be corrected in the file" in errors["said_m"]
    assert pl.read_parquet(tmp_path / "out" / "runs.parquet")["run_id"].to_list() == ["good"]


def test_input_dx_for_heights_only_files_never_redefines_a_file_with_distances(tmp_path: Path) -> None:
    """--input-dx (reader_defaults dx) is the interval of heights-only files. A file with its own
    distances (0.25 mm here) keeps them: it is neither read nor solved at 0.5 mm."""
    fine = roadtex.synthetic_pavement("dense_asphalt", length=0.8, dx=0.25e-3, seed=6)
    (tmp_path / "distances.csv").write_text(csv(np.round(fine.positions * 1e3, 3), np.round(fine.heights * 1e3, 4)))
    _, z = road()
    np.save(tmp_path / "heights.npy", z * 1e-3)
    from roadtex.errors import UnitConflictWarning

    with pytest.warns(UnitConflictWarning, match=r"distances\.csv: its distances are 0\.00025 m apart; the dx 0\.0005 m "
                                                 r"given is ignored"):
        assert roadtex.read_profile(tmp_path / "distances.csv", dx=0.5e-3).dx == pytest.approx(0.25e-3, rel=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitConflictWarning)   # heights only: the dx given is theirs, no conflict
        assert roadtex.read_profile(tmp_path / "heights.npy", dx=0.5e-3).dx == 0.5e-3
    options = roadtex.ProcessingOptions(youngs_moduli=(2e6,), error_budget_db=None, segment_length=0.25,
                                        reader_defaults={"dx": 0.5e-3})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnitConflictWarning)
        roadtex.process(roadtex.build_manifest(tmp_path), tmp_path / "out", options, quiet=True)
    runs = pl.read_parquet(tmp_path / "out" / "runs.parquet").sort("run_id")
    assert runs["run_id"].to_list() == ["distances", "heights"]
    assert runs["file_dx"].to_list() == pytest.approx([0.25e-3, 0.5e-3], rel=1e-9)
    assert runs["dx_used"].to_list() == runs["file_dx"].to_list()   # each run on its own readings


def test_quiet_prints_one_line_per_run_and_not_the_dask_clusters_log(tmp_path: Path) -> None:
    """--quiet --engine dask, as the README's table offers them together: roadtex's line per run,
    not the local cluster's some forty INFO lines (scheduler, nannies, workers)."""
    pytest.importorskip("distributed")
    import subprocess
    import sys

    x, z = road(length=0.6)
    for name in ("a.csv", "b.csv"):
        (tmp_path / name).write_text(csv(x, z))
    pl.DataFrame({"path": ["a.csv", "b.csv"]}).write_csv(tmp_path / "manifest.csv")
    done = subprocess.run([str(Path(sys.executable).parent / "roadtex"), "process", "manifest.csv", "--out", "out",
                           "--moduli", "2", "--error-budget", "off", "--engine", "dask", "--workers", "1", "--quiet"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stderr.splitlines()
    assert sum(" roadtex.archive run " in line for line in lines) == 2, done.stderr
    assert not [line for line in lines if " distributed." in line], done.stderr


@pytest.mark.parametrize("value", ["-1", "0", "nan", "inf", "0.2dB", "nonsense"])
def test_a_nonsense_error_budget_is_refused_naming_the_flag(tmp_path: Path, value: str,
                                                            capsys: pytest.CaptureFixture) -> None:
    x, z = road(length=0.6)
    (tmp_path / "a.csv").write_text(csv(x, z))
    pl.DataFrame({"path": ["a.csv"]}).write_csv(tmp_path / "manifest.csv")
    code = main(["process", str(tmp_path / "manifest.csv"), "--out", str(tmp_path / "out"), f"--error-budget={value}"])
    assert code == 2 and not (tmp_path / "out" / "runs.parquet").exists()
    assert f"--error-budget must be a positive number of dB (e.g. 0.2) or 'off', got {value!r}" in capsys.readouterr().err


def test_a_dx_given_for_heights_only_files_does_not_refuse_a_surface_table_with_positions(tmp_path: Path) -> None:
    """A surface as a long table of x, y, z (mm) on a 0.5 mm grid, read with dx = 0.25 mm given (the
    job's --input-dx meant for heights-only files): its positions' own grid is kept, with a warning."""
    surface = roadtex.synthetic_surface("dense_asphalt", length=0.1, width=0.01, dx=0.5e-3, seed=2)
    ny, nx = surface.heights.shape
    x, y = np.meshgrid(np.arange(nx) * 0.5, np.arange(ny) * 0.5)
    rows = "".join(f"{a:.3f},{b:.3f},{c * 1e3:.5f}\n" for a, b, c in zip(x.ravel(), y.ravel(), surface.heights.ravel()))
    (tmp_path / "scan.csv").write_text("x (mm),y (mm),z (mm)\n" + rows)
    from roadtex.errors import UnitConflictWarning

    with pytest.warns(UnitConflictWarning, match=r"scan\.csv: its x positions are 0\.0005 m apart; the dx 0\.00025 m "
                                                 r"given is ignored") as caught:
        read = roadtex.read_surface(tmp_path / "scan.csv", dx=0.25e-3)
    assert caught[0].filename == __file__
    assert read.dx == pytest.approx(0.5e-3, rel=1e-9) and read.heights.shape == (ny, nx)
    np.testing.assert_allclose(read.heights, np.round(surface.heights * 1e3, 5) * 1e-3, rtol=0, atol=1e-12)
    # positions off any grid are still refused
    (tmp_path / "scattered.csv").write_text("x (mm),y (mm),z (mm)\n0,0,1\n0.5,0,2\n1.3,0,1\n0,0.5,1\n0.5,0.5,2\n1.3,0.5,1\n")
    with pytest.raises(ProfileFormatError, match=r"scattered\.csv: not a regular grid"):
        roadtex.read_surface(tmp_path / "scattered.csv", dx=0.25e-3)


@pytest.mark.parametrize("excel", [True, False], ids=["sep-line", "semicolons"])
def test_a_manifest_saved_by_a_european_spreadsheet_is_read_as_written(tmp_path: Path, excel: bool) -> None:
    """Semicolons, Excel's sep= line, a byte-order mark, Windows line ends and decimal commas in the
    numeric columns (speed_kmh, dx): the same runs, reader options and metadata as a plain CSV."""
    x, z = road(length=0.6)
    (tmp_path / "a.csv").write_text(csv(x, z))
    np.save(tmp_path / "b.npy", z * 1e-3)
    text = ("sep=;\n" if excel else "") + "path;run_id;dx;speed_kmh;site\na.csv;a;;80,5;A1, km 12\nb.npy;b;0,0005;50;B2\n"
    (tmp_path / "manifest.csv").write_bytes(("\ufeff" + text).replace("\n", "\r\n").encode("utf-8"))
    manifest = read_manifest(tmp_path / "manifest.csv")
    assert manifest["run_id"].to_list() == ["a", "b"]
    assert manifest["speed_kmh"].to_list() == [80.5, 50.0] and manifest["dx"].to_list() == [None, 0.0005]
    assert manifest["site"].to_list() == ["A1, km 12", "B2"]
    assert [Path(p).name for p in manifest["path"]] == ["a.csv", "b.npy"]
