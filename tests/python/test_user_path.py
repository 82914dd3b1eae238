"""The README's bulk-job commands, exactly as written, on the real CAPTIF files and on the same
profiles re-exported the way colleagues send them (issue 14): every file processed or refused with
a clear reason, results agreeing with the clean file where they should."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from exports import readme_bulk_commands, write_colleague_exports

ROADTEX = Path(sys.executable).parent / "roadtex"
README = Path(__file__).resolve().parents[2] / "README.md"


def run_readme(survey: Path, work: Path, *, edit_manifest=None) -> list[subprocess.CompletedProcess]:
    """Runs the README's commands in ``work`` with SURVEY_FOLDER = ``survey``; ``edit_manifest(path)``
    runs after the manifest step, as a user editing the CSV in a spreadsheet."""
    commands = readme_bulk_commands(README)
    assert [c[1] for c in commands] == ["manifest", "process", "report"]
    done = []
    for argv in commands:
        argv = [str(survey) if arg == "SURVEY_FOLDER" else arg for arg in argv]
        done.append(subprocess.run([str(ROADTEX), *argv[1:]], cwd=work, capture_output=True, text=True, timeout=900))
        if argv[1] == "manifest" and edit_manifest is not None:
            edit_manifest(work / argv[argv.index("--out") + 1])
    return done


def test_readme_commands_on_the_real_captif_files(tmp_path: Path, captif_dir: Path) -> None:
    survey = tmp_path / "survey"
    survey.mkdir()
    for path in captif_dir.glob("*.dat"):
        (survey / path.name).write_bytes(path.read_bytes())
    manifest, process, report = run_readme(survey, tmp_path)
    for step in (manifest, process, report):
        assert step.returncode == 0, f"{step.args}: {step.stderr[-2000:]}"
    runs = pl.read_parquet(tmp_path / "results" / "runs.parquet")
    assert runs.height == 3 and pl.read_parquet(tmp_path / "results" / "errors.parquet").height == 0
    # one sampling interval for the whole job, and the plates (about 0.1 m) trimmed, nothing else
    assert runs["dx_used"].n_unique() == 1
    assert runs["trimmed_length"].is_between(0.08, 0.13).all(), runs["trimmed_length"]
    # MPD with its ISO validity, null never NaN
    assert runs["mpd_baselines"].min() >= 17 and (runs["mpd_valid_baselines"] <= runs["mpd_baselines"]).all()
    assert runs["mpd"].is_nan().sum() == 0
    assert (tmp_path / "results" / "report" / "report.html").is_file()


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory, captif_dir: Path) -> tuple[Path, dict]:
    folder = tmp_path_factory.mktemp("exports") / "from_colleagues"
    return folder, write_colleague_exports(captif_dir / "20211011_aylesbury_dec_station_0.dat", folder)


@pytest.fixture(scope="module")
def processed(exported: tuple[Path, dict], tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list]:
    folder, exports = exported
    work = tmp_path_factory.mktemp("work")

    def add_reader_columns(manifest: Path) -> None:
        table = pl.read_csv(manifest, infer_schema=False)
        names = [Path(p).name for p in table["path"]]
        for column in ("distance_unit", "height_unit", "dx"):
            values = [exports[name].get(column) for name in names]
            table = table.with_columns(pl.Series(column, [None if v is None else str(v) for v in values], pl.String))
        table.write_csv(manifest)

    return work, run_readme(folder, work, edit_manifest=add_reader_columns)


def test_colleagues_exports_are_processed_or_refused_with_a_reason(exported, processed) -> None:
    _, exports = exported
    work, (manifest, process, report) = processed
    assert manifest.returncode == 0, manifest.stderr
    assert process.returncode == 1, "a refused file must make the job exit 1"
    assert report.returncode == 0, report.stderr
    errors = pl.read_parquet(work / "results" / "errors.parquet")
    refused = {name: spec["refused"] for name, spec in exports.items() if "refused" in spec}
    assert sorted(Path(p).name for p in errors["path"]) == sorted(refused)
    for row in errors.iter_rows(named=True):
        name = Path(row["path"]).name
        assert name in row["message"] and refused[name] in row["message"], row["message"]
    runs = pl.read_parquet(work / "results" / "runs.parquet")
    assert sorted(Path(p).name for p in runs["path"]) == sorted(set(exports) - set(refused))
    assert "no_units_given" in (work / "results" / "report" / "report.html").read_text(encoding="utf-8")
    # a metadata block before the table fills the manifest's columns as a CAPTIF header does
    listed = pl.read_csv(work / "manifest.csv", infer_schema=False)
    block = listed.row(by_predicate=pl.col("path").str.ends_with("metadata_block.csv"), named=True)
    assert (block["site"], block["date"]) == ("CAPTIF", "2021-10-11"), block


def test_exports_agree_with_the_clean_file(processed) -> None:
    work, _ = processed
    runs = pl.read_parquet(work / "results" / "runs.parquet").with_columns(
        pl.col("path").map_elements(lambda p: Path(p).name, return_dtype=pl.String).alias("name"))
    clean = runs.row(by_predicate=pl.col("name") == "clean.dat", named=True)
    for row in runs.iter_rows(named=True):
        assert row["mpd"] == pytest.approx(clean["mpd"], rel=0.01), row["name"]
        # a spike or a drop-out code is never taken for a reference plate: the same road is kept
        assert row["length"] == pytest.approx(clean["length"], abs=1e-3), row["name"]
    spike = runs.row(by_predicate=pl.col("name") == "spike.dat", named=True)
    deep = runs.row(by_predicate=pl.col("name") == "deep_dropout.dat", named=True)
    assert (spike["spike_fraction"] + spike["outlier_fraction"]) * spike["points"] >= 1
    # the 20 readings of the drop-out code (the shares are of the readings kept: points solved, times
    # the readings a point averages where the pilot chose a coarser interval than the file's)
    assert deep["outlier_fraction"] * deep["points"] * deep["dx_used"] / deep["file_dx"] == pytest.approx(20, abs=1)
    segments = pl.read_parquet(work / "results" / "segments.parquet")
    by_run = {name: segments.filter(pl.col("run_id") == Path(name).stem)["contact_fraction"].to_numpy()
              for name in runs["name"]}
    # the same numbers in another file format give the same contact, to rounding, where they are
    # solved alike: the exports (no device in them) form their own group, whose pilot reads three of
    # its six runs and speaks for the others too, so it extrapolates and may choose another setting
    # than the CAPTIF files' pilot, which read every run of its group
    setting = {row["name"]: (row["dx_used"], row["refine"], row["tol_used"]) for row in runs.iter_rows(named=True)}
    exports = ("headerless.tsv", "european.csv", "xz.csv", "metadata_block.csv", "excel.csv")
    assert len({setting[name] for name in exports}) == 1
    first = exports[0] if setting[exports[0]] != setting["clean.dat"] else "clean.dat"
    for name in exports:
        np.testing.assert_allclose(by_run[name], by_run[first], atol=1e-9, err_msg=name)
    if setting[exports[0]] == setting["clean.dat"]:
        np.testing.assert_allclose(by_run["headerless.tsv"], by_run["clean.dat"], atol=1e-9)
    # heights only: the file's small position jitter is lost, so the grid differs by a fraction of a sample
    np.testing.assert_allclose(by_run["heights_only.npy"], by_run[first], atol=1e-3)
    # a removed spike or drop-out code changes the contact only locally (one segment in four)
    for name in ("spike.dat", "deep_dropout.dat"):
        assert np.abs(by_run[name] - by_run["clean.dat"]).max() < 0.05, name


def test_a_rerun_keeps_failures_on_record_until_retried(exported, processed, tmp_path: Path) -> None:
    folder, exports = exported
    work, _ = processed
    again = subprocess.run([str(ROADTEX), "process", "manifest.csv", "--out", "results/"], cwd=work,
                           capture_output=True, text=True, timeout=600)
    assert again.returncode == 1 and "0 failed" in again.stdout and "earlier" in again.stdout, again.stdout
    # the user gives the missing units, corrects the wrong one, and retries
    table = pl.read_csv(work / "manifest.csv", infer_schema=False)
    fixed = pl.col("path").str.ends_with("no_units_given.tsv") | pl.col("path").str.ends_with("mm_said_um.tsv")
    table = table.with_columns(
        pl.when(fixed).then(pl.lit("mm")).otherwise(pl.col("height_unit")).alias("height_unit"),
        pl.when(fixed).then(pl.lit("mm")).otherwise(pl.col("distance_unit")).alias("distance_unit"))
    table.write_csv(work / "manifest_fixed.csv")
    retried = subprocess.run([str(ROADTEX), "process", "manifest_fixed.csv", "--out", "results/", "--retry-failed"],
                             cwd=work, capture_output=True, text=True, timeout=600)
    assert retried.returncode == 0, retried.stdout + retried.stderr
    assert pl.read_parquet(work / "results" / "errors.parquet").height == 0
