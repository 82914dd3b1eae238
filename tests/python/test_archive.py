"""The bulk job: manifest checks, tables, errors, resume after SIGKILL, change detection, Dask."""

from __future__ import annotations

import errno
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import polars as pl
import pytest
from polars.testing import assert_frame_equal

import roadtex
from roads import job_road
from roadtex.archive import (
    BAND_SCHEMA,
    ERROR_SCHEMA,
    SEGMENT_SCHEMA,
    ArchiveWriteError,
    ManifestError,
    ProcessingOptions,
    build_manifest,
    process,
    read_manifest,
    read_profiles,
)
from roadtex.profiles import write_profile
from roadtex.profiles.pavements import synthetic_pavement

DX = 5e-4
# Small segments keep the tests quick; the physics is the same as with the default 0.5 m.
OPTIONS = ProcessingOptions(youngs_moduli=(2e6, 1e7), segment_length=0.128, tol=1e-8)
KINDS = ("dense_asphalt", "porous_asphalt", "cement_concrete")


def make_archive(folder: Path, runs: int = 3, length: float = 0.6, suffix: str = ".csv") -> Path:
    """Writes synthetic pavement runs and a manifest listing them; returns the manifest path."""
    folder.mkdir(parents=True, exist_ok=True)
    rows = []
    for i in range(runs):
        kind = KINDS[i % len(KINDS)]
        profile = synthetic_pavement(kind, length, DX, seed=i)
        path = write_profile(profile, folder / f"run{i:02d}{suffix}")
        rows.append({"path": path.name, "run_id": f"run{i:02d}", "site": f"site-{i}", "pavement": kind,
                     "speed_kmh": 80.0})
    manifest = folder / "manifest.csv"
    pl.DataFrame(rows).write_csv(manifest)
    return manifest


def tables(out: Path) -> dict[str, pl.DataFrame]:
    return {name: pl.read_parquet(out / f"{name}.parquet") for name in ("segments", "bands", "runs", "errors")}


@pytest.fixture(scope="module")
def archive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_archive(tmp_path_factory.mktemp("archive"))


@pytest.fixture(scope="module")
def reference(archive: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One uninterrupted run of the job: what every other way of running it must reproduce."""
    out = tmp_path_factory.mktemp("reference")
    summary = process(archive, out, OPTIONS, quiet=True, threads=1)
    assert summary.processed == 3 and summary.failed == 0
    return out


# ---------------------------------------------------------------- manifest


def test_manifest_paths_resolve_relative_to_manifest(archive: Path) -> None:
    table = read_manifest(archive)
    assert table["run_id"].to_list() == ["run00", "run01", "run02"]
    assert all(Path(p).is_absolute() and Path(p).exists() for p in table["path"])
    assert table.schema["speed_kmh"] == pl.Float64


@pytest.mark.parametrize("columns, message", [
    ({"path": ["a.csv"], "colour": ["red"]}, "unknown column"),
    ({"file": ["a.csv"]}, "no 'path' column"),
    ({"path": ["a.csv", "a.csv"]}, "appears twice"),
    ({"path": ["missing.csv"]}, "do not exist"),
    ({"path": ["a.csv"], "speed_kmh": ["fast"]}, "must be numeric"),
    ({"path": ["a.csv"], "speed_kmh": [0.0]}, "must be positive"),
])
def test_bad_manifest_is_refused_before_any_work(tmp_path: Path, columns: dict, message: str) -> None:
    (tmp_path / "a.csv").write_text("x")
    manifest = tmp_path / "manifest.csv"
    pl.DataFrame(columns).write_csv(manifest)
    out = tmp_path / "out"
    with pytest.raises(ManifestError, match=message):
        process(manifest, out, OPTIONS, quiet=True)
    assert not out.exists()


@pytest.mark.parametrize("options, message", [
    (dict(poisson=0.7), "poisson"), (dict(max_iterations=0), "max_iterations"),
    (dict(mpd_spike_alpha=0.0), "mpd_spike_alpha"), (dict(speed_kmh=-80.0), "speed_kmh"),
    (dict(youngs_moduli=(2e6, -1.0)), "youngs_moduli"), (dict(segment_overlap=0.6), "segment_overlap"),
])
def test_bad_options_are_refused_before_any_work(options: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ProcessingOptions(**options)


def test_empty_manifest_is_refused(tmp_path: Path) -> None:
    manifest = tmp_path / "manifest.csv"
    manifest.write_text("path,site\n")
    with pytest.raises(ManifestError, match="no runs"):
        read_manifest(manifest)


def test_build_manifest_lists_profile_files_with_their_metadata(tmp_path: Path) -> None:
    make_archive(tmp_path / "folder", runs=2)
    (tmp_path / "folder" / "notes.md").write_text("not a profile")
    table = build_manifest(tmp_path / "folder")
    assert table["run_id"].to_list() == ["run00", "run01"]
    assert read_manifest(table, base_dir=tmp_path).height == 2


def test_build_manifest_reads_captif_metadata(captif_dir: Path) -> None:
    table = build_manifest(captif_dir)
    assert table.height == 3
    assert table["wheel_path"].null_count() == 0 and table["date"].null_count() == 0


# ---------------------------------------------------------------- tables


def test_tables_have_the_documented_schemas_and_one_row_per_item(reference: Path) -> None:
    t = tables(reference)
    assert dict(t["segments"].schema) == SEGMENT_SCHEMA
    assert dict(t["bands"].schema) == BAND_SCHEMA
    assert dict(t["errors"].schema) == ERROR_SCHEMA and t["errors"].height == 0
    segments_per_run = t["runs"]["segments"].to_list()
    assert all(s >= 4 for s in segments_per_run)  # 0.6 m runs in 0.128 m segments
    assert t["segments"].height == sum(segments_per_run) * len(OPTIONS.youngs_moduli)
    bands_per_row = t["bands"].group_by("run_id", "segment", "youngs_modulus").len()["len"].unique()
    assert bands_per_row.len() == 1 and bands_per_row[0] >= 5
    assert t["segments"].select(pl.struct("run_id", "segment", "youngs_modulus").is_unique().all()).item()
    # Manifest order, then segment, then modulus in the order given: the same whatever finished first.
    assert t["segments"]["run_id"].unique(maintain_order=True).to_list() == ["run00", "run01", "run02"]
    assert t["segments"].equals(t["segments"].sort("run_id", "segment", "youngs_modulus"))


def test_segment_rows_hold_physics_that_could_fail(reference: Path) -> None:
    seg = pl.read_parquet(reference / "segments.parquet")
    assert seg["converged"].all() and (seg["residual"] <= OPTIONS.tol).all()
    assert ((seg["contact_fraction"] > 0) & (seg["contact_fraction"] <= 1)).all()
    assert (seg["mean_gap"] >= 0).all() and (seg["max_penetration"] >= seg["mean_penetration"]).all()
    assert (seg["max_pressure"] >= OPTIONS.mean_pressure).all()
    # Softer rubber reaches deeper into the texture, on every segment.
    wide = seg.pivot(on="youngs_modulus", index=["run_id", "segment"], values="mean_penetration")
    assert (wide["2000000.0"] > wide["10000000.0"]).all()
    assert seg["site"].to_list()[0] == "site-0" and (seg["speed_kmh"] == 80.0).all()


def test_segment_values_match_a_direct_call_of_the_core(archive: Path, reference: Path) -> None:
    """The job's numbers are those of roadtex.contact on the same conditioned segment, its readings
    joined by straight lines on the model grid the job states (runs.parquet: refine, model_dx)."""
    from roadtex.profiles import read_profile

    table = read_manifest(archive)
    run = pl.read_parquet(reference / "runs.parquet").filter(pl.col("run_id") == "run01")
    dx, refine = run["dx_used"].item(), run["refine"].item()
    assert run["model_dx"].item() == pytest.approx(dx / refine)
    profile = read_profile(table["path"][1]).conditioned(dx=dx, spike_alpha=OPTIONS.spike_alpha)
    segment = profile.segments(OPTIONS.segment_length, OPTIONS.segment_overlap).heights[2]
    road = job_road(segment, refine)[0]   # the job's road (monotone cubic), built independently
    r = roadtex.contact(road, profile.dx / refine, 1e7, OPTIONS.mean_pressure, tol=OPTIONS.tol)
    row = pl.read_parquet(reference / "segments.parquet").filter(
        (pl.col("run_id") == "run01") & (pl.col("segment") == 2) & (pl.col("youngs_modulus") == 1e7))
    assert row["contact_fraction"].item() == pytest.approx(r.contact_fraction)
    assert row["max_pressure"].item() == pytest.approx(float(r.pressure.max()))
    assert row["mean_gap"].item() == pytest.approx(float(r.depth_below_envelope.mean()))


def test_band_rows_frequency_is_speed_over_wavelength(reference: Path) -> None:
    bands = pl.read_parquet(reference / "bands.parquet")
    expected = (80.0 / 3.6) / bands["centre_wavelength"]
    assert np.allclose(bands["frequency"].to_numpy(), expected.to_numpy())
    finite = bands.filter(pl.col("texture_level").is_finite() & pl.col("enveloped_level").is_finite())
    assert finite.height > 0
    # Enveloping removes texture: the short wavelengths lose level on average.
    short = finite.filter(pl.col("centre_wavelength") < 5e-3)
    assert (short["enveloped_level"] - short["texture_level"]).mean() < 0


def test_mpd_per_segment_is_in_the_range_of_the_run(reference: Path) -> None:
    seg = pl.read_parquet(reference / "segments.parquet")
    runs = pl.read_parquet(reference / "runs.parquet")
    for run_id, run_mpd in runs.select("run_id", "mpd").iter_rows():
        values = seg.filter(pl.col("run_id") == run_id)["mpd"].drop_nulls().drop_nans()
        assert values.len() > 0
        assert values.min() <= run_mpd * 1.0001 and values.max() >= run_mpd * 0.9999


# ---------------------------------------------------------------- errors, resume, changes


def test_bad_file_is_recorded_and_the_rest_goes_on(tmp_path: Path, reference: Path) -> None:
    archive = make_archive(tmp_path / "a")
    (tmp_path / "a" / "broken.csv").write_text("distance (mm),height (mm)\n0,1\n0.5,garbage\n")
    (tmp_path / "a" / "empty.csv").write_text("")
    table = read_manifest(archive)
    rows = table.to_dicts()
    extra = [{**rows[0], "path": str(tmp_path / "a" / name), "run_id": name} for name in ("broken.csv", "empty.csv")]
    manifest = pl.DataFrame([rows[0], extra[0], rows[1], extra[1], rows[2]], schema=table.schema)
    summary = process(manifest, tmp_path / "out", OPTIONS, quiet=True)
    assert (summary.processed, summary.failed) == (3, 2)
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet")
    assert errors["run_id"].to_list() == ["broken.csv", "empty.csv"]
    assert (errors["stage"] == "read").all() and errors["message"].str.len_chars().min() > 10
    assert_frame_equal(pl.read_parquet(tmp_path / "out" / "segments.parquet"),
                       pl.read_parquet(reference / "segments.parquet"))


def test_rerun_does_no_work_and_changes_are_detected(tmp_path: Path, reference: Path) -> None:
    archive = make_archive(tmp_path / "a")
    out = tmp_path / "out"
    process(archive, out, OPTIONS, quiet=True)
    status_times = {p: p.stat().st_mtime_ns for p in (out / "runs").glob("*/status.json")}
    again = process(archive, out, OPTIONS, quiet=True)
    assert (again.processed, again.skipped) == (0, 3)
    assert status_times == {p: p.stat().st_mtime_ns for p in (out / "runs").glob("*/status.json")}

    # A changed input file is recomputed, alone.
    profile = synthetic_pavement("dense_asphalt", 0.6, DX, seed=99)
    write_profile(profile, tmp_path / "a" / "run01.csv")
    changed = process(archive, out, OPTIONS, quiet=True)
    assert (changed.processed, changed.skipped) == (1, 2)

    # Changed options recompute everything, and the tables follow the new options.
    options = ProcessingOptions(youngs_moduli=(5e6,), segment_length=0.128, tol=1e-8)
    redone = process(archive, out, options, quiet=True)
    assert redone.processed == 3
    assert pl.read_parquet(out / "segments.parquet")["youngs_modulus"].unique().to_list() == [5e6]


def _job(manifest: Path, out: Path) -> list[str]:
    return [sys.executable, "-m", "roadtex.cli", "process", str(manifest), "--out", str(out), "--quiet",
            "--moduli", *[str(e / 1e6) for e in OPTIONS.youngs_moduli], "--segment-length",
            str(OPTIONS.segment_length), "--tol", str(OPTIONS.tol), "--threads", "1"]


#: The job with a SIGKILL at a known point (argv[1], "kind:at"): "compute:N" as the N-th run's
#: compute starts (runs before it done, others in flight), "write:N" in the N-th table write after
#: its temporary file is written and before it is renamed (mid-write of a run's tables),
#: "combine:NAME" in the write of the combined table NAME (the job's last step). Deterministic:
#: a hook at a point of the job, not a race of a timer against it.
KILL_JOB = """
import os, signal, sys, threading
import roadtex.archive.combined as combine
import roadtex.archive.worker as worker
from roadtex.cli import main
kind, at = sys.argv[1].split(":")
lock, count = threading.Lock(), [0]
def due():
    with lock:
        count[0] += 1
        return count[0] == int(at)
def kill():
    os.kill(os.getpid(), signal.SIGKILL)
if kind == "compute":
    compute = worker.compute_run
    def killing(*args, **kwargs):
        if due():
            kill()
        return compute(*args, **kwargs)
    worker.compute_run = killing
else:
    write = worker.write_atomically   # the runs' tables (worker) and the combined ones (combine)
    def killing(path, fn, *args, **kwargs):
        if (kind == "write" and due()) or (kind == "combine" and path.name == at and path.parent.parent.name != "runs"):
            return write(path, lambda p: (fn(p), kill()), *args, **kwargs)
        return write(path, fn, *args, **kwargs)
    worker.write_atomically = combine.write_atomically = killing
sys.exit(main(sys.argv[2:]))
"""


def test_sigkill_at_known_points_then_resume_gives_identical_tables(tmp_path: Path) -> None:
    runs = 6
    archive = make_archive(tmp_path / "a", runs=runs, length=2.0)
    reference = tmp_path / "reference"
    assert subprocess.run(_job(archive, reference), capture_output=True).returncode == 0
    out = tmp_path / "out"
    done_at_kill = []
    for point in ("compute:1", "write:3", "compute:4", "combine:bands.parquet"):
        job = subprocess.run([sys.executable, "-c", KILL_JOB, point, *_job(archive, out)[3:]], capture_output=True)
        assert job.returncode == -signal.SIGKILL, (point, job.returncode, job.stderr[-2000:])
        done_at_kill.append(len(list((out / "runs").glob("*/status.json"))))
    # nothing done at the first run; a run's tables half written; some runs done (2 or 3: two in
    # flight); every run done, the combined tables half written
    assert done_at_kill[0] == 0 and 0 < done_at_kill[2] < runs and done_at_kill[3] == runs, done_at_kill
    assert list(out.rglob("*.tmp")), "the kills left temporary files to clean up"
    assert subprocess.run(_job(archive, out), capture_output=True).returncode == 0
    assert not list(out.rglob("*.tmp")), "temporary files of killed jobs are cleaned up on resume"
    for name in ("segments", "bands", "runs", "errors"):
        assert_frame_equal(pl.read_parquet(out / f"{name}.parquet"), pl.read_parquet(reference / f"{name}.parquet"))


def test_unwritable_output_folder_gives_a_clear_error(tmp_path: Path, archive: Path) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    with pytest.raises(ArchiveWriteError, match="not writable"):
        process(archive, blocker / "out", OPTIONS, quiet=True)


def test_full_disk_stops_the_job_without_corrupting_finished_runs(tmp_path: Path, archive: Path,
                                                                  reference: Path, monkeypatch) -> None:
    out = tmp_path / "out"
    original = pl.DataFrame.write_parquet
    calls = {"n": 0}

    def write_until_full(self, file, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] > 4:  # the first run's tables fit, then the disk is full
            raise OSError(errno.ENOSPC, "No space left on device")
        return original(self, file, *args, **kwargs)

    monkeypatch.setattr(pl.DataFrame, "write_parquet", write_until_full)
    with pytest.raises(ArchiveWriteError, match="No space left"):
        process(archive, out, OPTIONS, quiet=True)
    monkeypatch.setattr(pl.DataFrame, "write_parquet", original)
    assert not list(out.rglob("*.tmp"))
    done = sorted(p.parent.name for p in (out / "runs").glob("*/status.json"))
    assert len(done) < 3  # two runs are in flight at a time: at most one finished before the disk filled
    summary = process(archive, out, OPTIONS, quiet=True)
    assert (summary.processed, summary.skipped) == (3 - len(done), len(done))
    assert_frame_equal(pl.read_parquet(out / "segments.parquet"), pl.read_parquet(reference / "segments.parquet"))


# ---------------------------------------------------------------- profiles, engines, CLI


def test_kept_profiles_read_back_by_run_and_position(tmp_path: Path, archive: Path) -> None:
    options = ProcessingOptions(youngs_moduli=(2e6,), segment_length=0.128, tol=1e-8, keep_profiles=True)
    process(archive, tmp_path / "out", options, quiet=True)
    part = read_profiles(tmp_path / "out", run_id="run02", start=0.1, end=0.3)
    assert part["run_id"].unique().to_list() == ["run02"]
    assert part["position"].min() >= 0.1 and part["position"].max() < 0.3
    assert (part["envelope"] >= part["height"] - 1e-12).all() and (part["pressure"] >= 0).all()
    assert part["position"].is_sorted()
    with pytest.raises(FileNotFoundError, match="keep_profiles"):
        read_profiles(tmp_path / "out", run_id="nope")


def test_dask_engine_gives_the_same_tables_as_the_local_engine(tmp_path: Path, archive: Path, reference: Path) -> None:
    pytest.importorskip("distributed", reason="dask.distributed is a dev requirement; install roadtex[dask]")
    summary = process(archive, tmp_path / "out", OPTIONS, engine="dask", workers=2, quiet=True)
    assert summary.processed == 3
    for name in ("segments", "bands", "runs", "errors"):
        assert_frame_equal(pl.read_parquet(tmp_path / "out" / f"{name}.parquet"),
                           pl.read_parquet(reference / f"{name}.parquet"))


def test_cli_without_dask_installed_says_which_extra_to_install(tmp_path: Path, archive: Path,
                                                               monkeypatch: pytest.MonkeyPatch,
                                                               capsys: pytest.CaptureFixture) -> None:
    """--engine dask on a machine without dask.distributed: exit 2 and the extra to install, no traceback."""
    from roadtex.cli import main

    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    assert main(["process", str(archive), "--out", str(tmp_path / "out"), "--engine", "dask", "--quiet"]) == 2
    assert "roadtex[dask]" in capsys.readouterr().err


def test_cli_process_runs_end_to_end_and_reports_failures_by_exit_code(tmp_path: Path, archive: Path) -> None:
    done = subprocess.run(_job(archive, tmp_path / "out"), capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "3 processed" in done.stdout
    bad = tmp_path / "bad.csv"
    pl.DataFrame({"path": ["nowhere.csv"]}).write_csv(bad)
    failed = subprocess.run(_job(bad, tmp_path / "out2"), capture_output=True, text=True)
    assert failed.returncode == 2 and "do not exist" in failed.stderr


def test_real_captif_archive_end_to_end(tmp_path: Path, captif_dir: Path) -> None:
    """The three real CAPTIF chip-seal files through the whole job: plates trimmed, MPD as roadtex.mpd."""
    from roadtex.profiles import mpd, read_profile

    manifest = build_manifest(captif_dir)
    options = ProcessingOptions(youngs_moduli=(2e6, 1e7), dx=2e-4, mpd_spike_alpha=6.0, tol=1e-8)
    summary = process(manifest, tmp_path / "out", options, quiet=True)
    assert (summary.processed, summary.failed) == (3, 0)
    runs = pl.read_parquet(tmp_path / "out" / "runs.parquet")
    for path, run_mpd, length in runs.select("path", "mpd", "length").iter_rows():
        assert run_mpd == mpd(read_profile(path), spike_alpha=6.0).mpd
        assert 2.5e-3 < run_mpd < 4e-3  # coarse chip seals (captif-slp publishes 3.0 to 3.4 mm)
        assert 1.5 < length < 1.95      # about 1.92 m measured, less the reference plates
    seg = pl.read_parquet(tmp_path / "out" / "segments.parquet")
    assert seg["converged"].all()
    assert seg["wheel_path"].null_count() == 0 and seg["date"].null_count() == 0
    # Chip seal is positive texture: the rubber rests on the chip tops, far from full contact.
    assert seg["contact_fraction"].max() < 0.6
