"""The bulk job against faults of its own output and of what it reads back (issue 29): a read-only
file system mid-write, unusable combined tables, corrupt per-run files, manifest order, concurrent
jobs on one folder, job-wide options checked before any work."""

from __future__ import annotations

import errno
import os
import shutil
import signal
import socket
import subprocess
import sys
import warnings
from pathlib import Path

import polars as pl
import pytest
from polars.testing import assert_frame_equal

from roadtex.archive import ProcessingOptions, process
from roadtex.archive.planning import plan_job
from roadtex.archive.store import job_lock, write_atomically
from roadtex.cli import main
from roadtex.errors import ArchiveWriteError, ErrorBudgetWarning, OutputInUseError
from roadtex.profiles import write_profile
from roadtex.profiles.pavements import synthetic_pavement


def test_a_read_only_file_system_reports_the_writes_error_not_the_cleanups(tmp_path: Path,
                                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    def write(path: Path) -> None:
        path.write_bytes(b"partial")
        raise OSError(errno.EROFS, "Read-only file system")

    def unlink(self: Path, missing_ok: bool = False) -> None:
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr(Path, "unlink", unlink)
    with pytest.raises(ArchiveWriteError, match=r"cannot write .*table\.parquet: Read-only file system \(and its "
                                                r"temporary file .* could not be removed") as caught:
        write_atomically(tmp_path / "table.parquet", write)
    assert caught.value.errno == errno.EROFS


def test_a_write_failure_without_an_errno_does_not_say_errno_none(tmp_path: Path) -> None:
    def write(path: Path) -> None:
        raise pl.exceptions.ComputeError("failed to write: No space left on device (os error 28)")

    with pytest.raises(ArchiveWriteError) as caught:
        write_atomically(tmp_path / "table.parquet", write)
    assert "Errno" not in str(caught.value)
    assert str(caught.value).startswith("cannot write ")


# --------------------------------------------------------------------------------------------
# What the job wrote is verified before it is trusted again
# --------------------------------------------------------------------------------------------

DX = 5e-4
OPTIONS = ProcessingOptions(youngs_moduli=(1e7,), dx=DX, segment_length=0.128, tol=1e-6, error_budget_db=None)


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> tuple[pl.DataFrame, Path]:
    """A two-run job, done once (the reference: its tables as written)."""
    folder = tmp_path_factory.mktemp("runs")
    rows = [{"path": str(write_profile(synthetic_pavement(kind, 0.6, DX, seed=i), folder / f"r{i}.parquet")),
             "run_id": f"r{i}"} for i, kind in enumerate(("dense_asphalt", "porous_asphalt"))]
    manifest = pl.DataFrame(rows)
    out = tmp_path_factory.mktemp("out")
    summary = process(manifest, out, OPTIONS, quiet=True, threads=1)
    assert (summary.processed, summary.failed) == (2, 0)
    return manifest, out


def copy_of(finished: tuple[pl.DataFrame, Path], tmp_path: Path) -> Path:
    out = tmp_path / "out"
    shutil.copytree(finished[1], out)
    return out


def garble(path: Path, offset: int, count: int = 200) -> None:
    data = bytearray(path.read_bytes())
    data[offset:offset + count] = bytes(range(count))
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("damage", ["truncated", "garbled"])
def test_a_damaged_combined_table_is_refused_by_the_report_and_rebuilt_by_a_rerun(
        finished, tmp_path: Path, damage: str, capsys: pytest.CaptureFixture[str]) -> None:
    out = copy_of(finished, tmp_path)
    combined = out / "segments.parquet"
    if damage == "truncated":
        combined.write_bytes(combined.read_bytes()[: combined.stat().st_size // 2])
    else:
        garble(combined, combined.stat().st_size // 3)
    assert main(["report", str(out)]) == 2
    assert "segments.parquet" in capsys.readouterr().err
    summary = process(finished[0], out, OPTIONS, quiet=True, threads=1)
    assert summary.skipped == 2
    assert combined.read_bytes() == (finished[1] / "segments.parquet").read_bytes()


def test_a_damaged_per_run_file_is_recomputed_on_rerun(finished, tmp_path: Path) -> None:
    out = copy_of(finished, tmp_path)
    per_run = out / "runs" / "r1" / "segments.parquet"
    per_run.write_bytes(per_run.read_bytes()[:100])
    summary = process(finished[0], out, OPTIONS, quiet=True, threads=1)
    assert (summary.skipped, summary.processed) == (1, 1)
    assert per_run.read_bytes() == (finished[1] / "runs" / "r1" / "segments.parquet").read_bytes()
    assert_frame_equal(pl.read_parquet(out / "segments.parquet"), pl.read_parquet(finished[1] / "segments.parquet"))


def test_the_plan_does_not_depend_on_the_manifests_order(tmp_path: Path) -> None:
    # six runs of one group: the pilot reads three spread over them (positions 0, 2, 5), a
    # different three when the manifest is reversed unless the runs are put in a stable order
    rows = [{"path": str(write_profile(synthetic_pavement(kind, 0.6, DX, seed=i), tmp_path / f"p{i}.parquet")),
             "run_id": f"p{i}"}
            for i, kind in enumerate(["dense_asphalt", "porous_asphalt", "cement_concrete"] * 2)]
    options = ProcessingOptions(youngs_moduli=(1e7,), segment_length=0.128, error_budget_db=0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ErrorBudgetWarning)
        forward, _ = plan_job(rows, options, threads=1)
        backward, _ = plan_job(rows[::-1], options, threads=1)
    def decided(plan):   # what the pilots chose and estimated (their measured seconds vary)
        return [(p.name, p.pilot_runs, p.data_dx, p.refine, p.tol, p.band_error_db, p.worst_error_db)
                for p in plan.pilots]
    assert decided(forward) and decided(forward) == decided(backward)


def test_a_second_job_on_a_folder_is_refused_naming_the_first(finished, tmp_path: Path) -> None:
    out = copy_of(finished, tmp_path)
    with job_lock(out):
        with pytest.raises(OutputInUseError, match=rf"in use by another roadtex job \(pid {os.getpid()} on "
                                                   rf"{socket.gethostname()}, started 20\d\d-"):
            process(finished[0], out, OPTIONS, quiet=True, threads=1)
    assert process(finished[0], out, OPTIONS, quiet=True, threads=1).skipped == 2   # released: the folder is free


def test_the_lock_of_a_killed_job_is_taken_over(finished, tmp_path: Path) -> None:
    out = copy_of(finished, tmp_path)
    holder = subprocess.Popen([sys.executable, "-c", "import sys, time; from pathlib import Path; "
                               "from roadtex.archive.store import job_lock\n"
                               f"with job_lock(Path({str(out)!r})):\n    print('held', flush=True); time.sleep(60)"],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        with pytest.raises(OutputInUseError, match=rf"pid {holder.pid} "):
            process(finished[0], out, OPTIONS, quiet=True, threads=1)
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait()
    assert process(finished[0], out, OPTIONS, quiet=True, threads=1).skipped == 2
