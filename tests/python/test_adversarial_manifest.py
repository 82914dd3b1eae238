"""The manifest and the command line against what a user may hand them (issue 29): colliding file
names, hostile run ids, other encodings, job-wide options refused before any work."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from roadtex.archive import ProcessingOptions, build_manifest, job, process, read_manifest
from roadtex.archive.manifest import unlisted_files
from roadtex.cli import main
from roadtex.errors import InvalidInputError, ManifestError, MissingDependencyError, RoadtexWarning

DX = 5e-4


def write_csv(path: Path, seed: int = 0) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    heights = np.random.default_rng(seed).normal(0.0, 5e-4, 400)
    lines = ["distance_m,height_m", *(f"{i * DX:.6f},{z:.8f}" for i, z in enumerate(heights))]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_generated_run_ids_are_made_unique_and_said(tmp_path: Path) -> None:
    folder = tmp_path / "survey"
    for name in ("a/x.csv", "a_x.csv", "x.csv", "b/a/x.csv"):
        write_csv(folder / name)
    with pytest.warns(RoadtexWarning, match=r"2 file\(s\) share a name .*b/a/x\.csv -> b_a_x; x\.csv -> x-2"):
        table = build_manifest(folder)
    ids = dict(zip((Path(p).relative_to(folder.resolve()).as_posix() for p in table["path"]), table["run_id"]))
    assert ids == {"a/x.csv": "x", "a_x.csv": "a_x", "b/a/x.csv": "b_a_x", "x.csv": "x-2"}


@pytest.fixture
def one_run(tmp_path: Path) -> Path:
    manifest = tmp_path / "manifest.csv"
    manifest.write_text(f"path,run_id\n{write_csv(tmp_path / 'r.csv')},r\n")
    return manifest


@pytest.mark.parametrize("flags, said", [
    (["--threads", "0"], "threads must be at least 1"),
    (["--tol", "2"], "tol must be below 1"),
    (["--input-dx", "0"], "--input-dx"),
    (["--height-unit", "furlong"], "unknown unit 'furlong'"),
    (["--segment-length", "1e-9"], "segment_length = 1e-09 m is shorter than 0.01 m"),
])
def test_job_wide_option_errors_are_refused_before_any_work(one_run: Path, tmp_path: Path, flags: list[str], said: str,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert main(["process", str(one_run), "--out", str(out), "--quiet", *flags]) == 2
    assert said in capsys.readouterr().err
    assert not out.exists()


def test_the_dask_engine_without_dask_is_refused_before_the_pilot(one_run: Path, tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "distributed" else real(name, *a))

    def no_pilot(*args: object, **kwargs: object) -> None:
        raise AssertionError("the pilot ran before the engine was checked")

    monkeypatch.setattr(job, "plan_job", no_pilot)
    with pytest.raises(MissingDependencyError, match="needs dask.distributed"):
        process(one_run, tmp_path / "out", ProcessingOptions(segment_length=0.1), engine="dask")


@pytest.mark.parametrize("run_id, said", [
    ("r" * 300, r"run id 'rrrr.*'\.\.\. is 300 bytes long; at most 200"),
    ("bad\x00id", r"run id 'bad\\x00id' contains a control character"),
])
def test_run_ids_that_cannot_name_a_folder_are_refused_at_the_manifest_naming_the_row(tmp_path: Path, run_id: str,
                                                                                     said: str) -> None:
    good = write_csv(tmp_path / "good.csv")
    rows = pl.DataFrame({"path": [str(good), str(write_csv(tmp_path / "other.csv", 1))], "run_id": ["good", run_id]})
    with pytest.raises(ManifestError, match=r"data row 2 .*column 'run_id'.*" + said):
        read_manifest(rows)


def test_a_utf16_manifest_is_read_and_one_with_nul_bytes_refused(tmp_path: Path) -> None:
    path = write_csv(tmp_path / "r.csv")
    text = f"path,run_id,speed_kmh\n{path},r,80\n"
    manifest = tmp_path / "manifest.csv"
    manifest.write_bytes(text.encode("utf-16"))   # with its byte-order mark, as Excel's "Unicode text"
    table = read_manifest(manifest)
    assert table["run_id"].to_list() == ["r"] and table["speed_kmh"].to_list() == [80.0]
    manifest.write_bytes(text.encode("utf-16-le"))   # no byte-order mark
    with pytest.raises(ManifestError, match=r"contains NUL bytes, so it is not UTF-8 text"):
        read_manifest(manifest)


def test_a_symlink_loop_is_reported_not_left_out_silently(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "survey"
    write_csv(folder / "good.csv")
    (folder / "loop.csv").symlink_to(folder / "loop.csv")
    (folder / "gone.csv").symlink_to(folder / "deleted.csv")
    notes = unlisted_files(folder)
    assert notes == ["gone.csv: a symbolic link that points to nothing",
                     "loop.csv: a symbolic link that loops (it leads back to itself)"]
    assert main(["manifest", str(folder), "--out", str(tmp_path / "manifest.csv")]) == 0
    assert "loop.csv: a symbolic link that loops" in capsys.readouterr().err


def test_unknown_columns_are_listed_briefly(tmp_path: Path) -> None:
    # found by fuzzing: a manifest line duplicated into its header listed every cell back
    path = write_csv(tmp_path / "r.csv")
    header = ",".join(["path", *(f"column_{i}_" + "x" * 50 for i in range(40))])
    manifest = tmp_path / "manifest.csv"
    manifest.write_text(header + "\n" + ",".join([str(path), *["1"] * 40]) + "\n")
    with pytest.raises(ManifestError, match=r"unknown column\(s\) 'column_0_xxxxxxxxxxxxxxx'\.\.\., .* and 32 more") as caught:
        read_manifest(manifest)
    assert len(str(caught.value)) < 800


@pytest.mark.parametrize("where", ["/dev/zero", "folder"])
def test_a_path_that_is_not_a_regular_file_is_that_runs_failure_not_a_hang(tmp_path: Path, where: str) -> None:
    # found looking for the next hang: /dev/zero passed the manifest check, then hashing it for the
    # run's fingerprint never ended. It is that run's recorded failure (one bad row never stops a
    # job), and nothing reads or hashes it.
    import signal

    path = where if where.startswith("/") else str(tmp_path / "a-folder")
    if not where.startswith("/"):
        Path(path).mkdir()
    rows = pl.DataFrame({"path": [str(write_csv(tmp_path / "good.csv")), path], "run_id": ["good", "odd"]})
    signal.alarm(60)   # a hang fails the test instead of the suite
    try:
        summary = process(rows, tmp_path / "out", ProcessingOptions(segment_length=0.1, error_budget_db=None), quiet=True)
    finally:
        signal.alarm(0)
    assert summary.failed == 1
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet")
    assert errors["run_id"].to_list() == ["odd"] and "not a regular file" in errors["message"][0]


def test_a_local_dask_cluster_of_no_workers_is_refused_not_waited_on(one_run: Path, tmp_path: Path) -> None:
    # found probing the command line: --engine dask --workers 0 waited forever for a worker
    with pytest.raises(InvalidInputError, match=r"workers must be at least 1"):
        process(one_run, tmp_path / "out", ProcessingOptions(segment_length=0.1), engine="dask", workers=0)
    assert not (tmp_path / "out").exists()
