"""Faults in the bulk job beyond those of test_archive.py (SIGKILL and resume, a bad CSV, an
unwritable folder, a full disk while writing a run).

Each test puts one fault in the middle of an archive of good runs, or into one step of the
job, and checks three things: the fault is reported where the issue says (errors.parquet with
the stage and a message, or a clear ArchiveWriteError), the good runs give exactly the tables
of a job without the fault, and nothing already written is corrupted.

Real data: the CAPTIF files are copied (and cut) into tmp_path, never touched in place.
"""

from __future__ import annotations

import errno
import shutil
from pathlib import Path

import numpy as np
import polars as pl
import pytest
from polars.testing import assert_frame_equal

from roadtex.archive import ArchiveWriteError, ProcessingOptions, process
from roadtex.archive.schemas import PLAN_BAND_COLUMNS, PLAN_RUN_COLUMNS
from roadtex.profiles import Profile, read_profile, write_profile
from roadtex.profiles.pavements import synthetic_pavement

DX = 5e-4
OPTIONS = ProcessingOptions(youngs_moduli=(2e6, 1e7), dx=DX, segment_length=0.128, mpd_spike_alpha=6.0, tol=1e-8)
KINDS = ("dense_asphalt", "porous_asphalt", "cement_concrete")
TABLES = ("segments", "bands", "runs")


def good_runs(folder: Path, runs: int = 3, suffix: str = ".parquet") -> list[dict]:
    """Synthetic pavement runs of 0.6 m written to ``folder``; their manifest rows."""
    folder.mkdir(parents=True, exist_ok=True)
    rows = []
    for i in range(runs):
        path = write_profile(synthetic_pavement(KINDS[i % 3], 0.6, DX, seed=i), folder / f"run{i:02d}{suffix}")
        rows.append({"path": str(path), "run_id": f"run{i:02d}", "speed_kmh": 80.0})
    return rows


def manifest(rows: list[dict]) -> pl.DataFrame:
    return pl.DataFrame(rows, schema={"path": pl.String, "run_id": pl.String, "speed_kmh": pl.Float64})


def table(out: Path, name: str) -> pl.DataFrame:
    return pl.read_parquet(out / f"{name}.parquet")


@pytest.fixture(scope="module")
def archive(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[dict], Path]:
    """Three good runs and the tables of a job on them alone (the reference)."""
    folder = tmp_path_factory.mktemp("good")
    rows = good_runs(folder)
    out = tmp_path_factory.mktemp("reference")
    summary = process(manifest(rows), out, OPTIONS, quiet=True, threads=1)
    assert (summary.processed, summary.failed) == (3, 0)
    return rows, out


def run_with_bad_file(tmp_path: Path, archive, bad: Path, *, expect_error: bool = True) -> tuple[Path, pl.DataFrame]:
    """The good runs with ``bad`` listed between the first and the second; returns the output
    folder and errors.parquet, after checking that the good runs' tables are the reference's."""
    rows, reference = archive
    listed = [rows[0], {"path": str(bad), "run_id": "bad", "speed_kmh": 80.0}, *rows[1:]]
    out = tmp_path / "out"
    summary = process(manifest(listed), out, OPTIONS, quiet=True, threads=1)
    errors = table(out, "errors")
    if expect_error:
        assert (summary.processed, summary.failed) == (3, 1)
        assert errors["run_id"].to_list() == ["bad"]
        assert len(errors["message"][0]) > 15
        for name in TABLES:
            assert_frame_equal(table(out, name), table(reference, name), check_exact=True)
        assert not (out / "runs" / "bad" / "segments.parquet").exists()
    return out, errors


# --------------------------------------------------------------------------------------------
# a truncated real CAPTIF file


@pytest.fixture(scope="module")
def captif_bytes(captif_dir: Path) -> bytes:
    return sorted(captif_dir.glob("*.dat"))[0].read_bytes()


def cut_captif(data: bytes, where: str) -> bytes:
    """The CAPTIF file's bytes, cut at a point of the kind named."""
    marker = data.index(b"*****DATA*****")
    middle = data.index(b"\n", len(data) // 2) + 1  # the start of a data row near the middle
    return {
        "in the metadata": data[:100],
        "after the data marker": data[:marker + 20],
        "in the middle of a data row": data[:middle + 9],
        "just after a row's second field": data[:data.index(b"\t", middle + 1) + 6],
    }[where]


@pytest.mark.parametrize("where", ["in the metadata", "after the data marker", "in the middle of a data row",
                                   "just after a row's second field"])
def test_truncated_captif_file_is_recorded_and_the_rest_goes_on(tmp_path, archive, captif_bytes, where):
    """A real CAPTIF file cut short (as by an interrupted copy), listed between good runs: the
    read stage fails with a message saying what is wrong, the good runs' tables are exactly
    those of a job without it."""
    bad = tmp_path / "cut.dat"
    bad.write_bytes(cut_captif(captif_bytes, where))
    _, errors = run_with_bad_file(tmp_path, archive, bad)
    assert errors["stage"].to_list() == ["read"]
    assert errors["error_type"].to_list() == ["ProfileFormatError"]
    assert any(word in errors["message"][0] for word in ("truncated", "missing value", "cannot read", "header"))


def test_whole_captif_file_goes_through_next_to_the_cut_ones(tmp_path, archive, captif_bytes):
    """Control for the tests above: the uncut copy is processed (so it is the cut that fails)."""
    good = tmp_path / "whole.dat"
    good.write_bytes(captif_bytes)
    out, errors = run_with_bad_file(tmp_path, archive, good, expect_error=False)
    assert errors.height == 0
    assert "bad" in table(out, "runs")["run_id"].to_list()


def test_captif_file_cut_at_a_line_end_reads_as_a_shorter_run(tmp_path, archive, captif_bytes):
    """A CAPTIF file cut exactly at the end of a data row cannot be told from a shorter
    measurement (the format records no row count): it is processed as a shorter run. Documented
    limitation; the run's points then fall short of the whole file's."""
    whole = tmp_path / "whole.dat"
    whole.write_bytes(captif_bytes)
    cut = tmp_path / "cut.dat"
    cut.write_bytes(captif_bytes[:captif_bytes.index(b"\n", len(captif_bytes) // 2) + 1])
    assert read_profile(cut).heights.size < 0.6 * read_profile(whole).heights.size
    out, errors = run_with_bad_file(tmp_path, archive, cut, expect_error=False)
    assert errors.height == 0
    runs = table(out, "runs")
    assert runs.filter(pl.col("run_id") == "bad")["length"].item() < 1.2


def test_captif_file_cut_inside_its_last_number_is_recorded(tmp_path, archive, captif_bytes):
    bad = tmp_path / "cut.dat"
    bad.write_bytes(captif_bytes[:len(captif_bytes) - 4])
    _, errors = run_with_bad_file(tmp_path, archive, bad)
    assert errors["stage"].to_list() == ["read"]


# --------------------------------------------------------------------------------------------
# a corrupt Parquet file


def corrupt_parquet(path: Path, how: str) -> None:
    data = path.read_bytes()
    if how == "truncated":
        path.write_bytes(data[:len(data) // 2])
    elif how == "footer garbled":
        path.write_bytes(data[:-40] + bytes(range(40)))
    elif how == "header garbled":
        path.write_bytes(b"XXXX" + data[4:])
    elif how == "data garbled":  # 8 bytes flipped in the column data: values become absurd
        b = bytearray(data)
        for k in range(8):
            b[11402 % len(b) + k] ^= 0xFF
        path.write_bytes(bytes(b))
    elif how == "no height column":
        pl.DataFrame({"distance_m": np.arange(100) * DX, "colour": ["red"] * 100}).write_parquet(path)
    elif how == "no rows":
        pl.DataFrame({"distance_m": pl.Series([], dtype=pl.Float64), "height_m": pl.Series([], dtype=pl.Float64)}
                     ).write_parquet(path)
    elif how == "only drop-outs":
        pl.DataFrame({"distance_m": np.arange(100) * DX, "height_m": np.full(100, np.nan)}).write_parquet(path)
    else:
        raise AssertionError(how)


@pytest.mark.parametrize("how", ["truncated", "footer garbled", "data garbled", "no height column", "no rows",
                                 "only drop-outs"])
def test_corrupt_parquet_file_is_recorded_and_the_rest_goes_on(tmp_path, archive, how):
    """A Parquet run file that is cut, garbled, lacks a height column, has no rows or only
    drop-outs, listed between good runs: read stage error with a message; good runs exact."""
    bad = write_profile(synthetic_pavement("dense_asphalt", 0.6, DX, seed=9), tmp_path / "bad.parquet")
    if how == "data garbled":
        assert len(bad.read_bytes()) > 11410
    corrupt_parquet(bad, how)
    _, errors = run_with_bad_file(tmp_path, archive, bad)
    assert errors["stage"].to_list() == ["read"]


def test_parquet_file_with_a_garbled_leading_magic_but_intact_data_is_read_right(tmp_path):
    """Parquet keeps its schema and offsets in the footer: a garbled leading "PAR1" with the data
    intact is read, and gives exactly the heights written (nothing silently different)."""
    profile = synthetic_pavement("dense_asphalt", 0.6, DX, seed=9)
    path = write_profile(profile, tmp_path / "p.parquet")
    corrupt_parquet(path, "header garbled")
    back = read_profile(path, format="parquet")
    assert np.array_equal(back.heights, profile.heights) and np.array_equal(back.positions, profile.positions)


def test_csv_cut_inside_a_quoted_field_is_recorded(tmp_path, archive):
    """A CSV run cut right after an opening quote, amid good runs: a read error, the rest goes on."""
    bad = tmp_path / "quoted.csv"
    bad.write_bytes(b'distance (mm),height (mm)\n0,1\n0.5,2\n1,"')
    _, errors = run_with_bad_file(tmp_path, archive, bad)
    assert errors["stage"].to_list() == ["read"]


def test_directory_listed_as_a_run_is_recorded(tmp_path, archive):
    """A manifest entry that names a folder (a copy gone wrong) is a read error, not a crash."""
    folder = tmp_path / "not-a-file.parquet"
    folder.mkdir()
    _, errors = run_with_bad_file(tmp_path, archive, folder)
    assert errors["stage"].to_list() == ["read"]


def test_run_shorter_than_one_segment_is_recorded(tmp_path, archive):
    """A valid but 5 cm long run holds neither one 100 mm MPD baseline nor one 0.128 m segment:
    an error at the first stage that needs the length (mpd), saying so."""
    short = write_profile(Profile.from_heights(1e-4 * np.sin(np.arange(100.0)), DX), tmp_path / "short.parquet")
    _, errors = run_with_bad_file(tmp_path, archive, short)
    assert errors["stage"].to_list() == ["mpd"] and "shorter than one" in errors["message"][0]


def test_file_corrupted_between_two_jobs_leaves_no_stale_results(tmp_path, archive):
    """A run that was processed, then its file corrupted, then the job run again: the run moves
    from the tables to errors.parquet (its old numbers are not kept as if current), and the
    other runs are not recomputed."""
    rows, reference = archive
    folder = tmp_path / "copy"
    folder.mkdir()
    copied = []
    for row in rows:
        target = folder / Path(row["path"]).name
        shutil.copy(row["path"], target)
        copied.append({**row, "path": str(target)})
    out = tmp_path / "out"
    assert process(manifest(copied), out, OPTIONS, quiet=True).processed == 3
    corrupt_parquet(Path(copied[1]["path"]), "truncated")
    again = process(manifest(copied), out, OPTIONS, quiet=True)
    assert (again.processed, again.skipped, again.failed) == (0, 2, 1)
    assert table(out, "errors")["run_id"].to_list() == ["run01"]
    for name in TABLES:
        expected = table(reference, name).filter(pl.col("run_id") != "run01")
        got = table(out, name)
        if name == "runs":  # the copies live elsewhere
            expected, got = expected.drop("path"), got.drop("path")
        # the plan's error estimates come from this job's pilot, which could not read run01 now
        plan_columns = [c for c in (*PLAN_BAND_COLUMNS, *PLAN_RUN_COLUMNS) if c in got.columns]
        assert_frame_equal(got.drop(plan_columns), expected.drop(plan_columns), check_exact=True)


# --------------------------------------------------------------------------------------------
# runs that cannot be solved to tolerance


def test_unconverged_segments_are_kept_and_flagged_not_hidden(tmp_path, archive):
    """max_iterations=1: the job finishes, records no error, and every segment row says
    honestly whether it converged, with its residual (> tol where it did not)."""
    rows, _ = archive
    options = ProcessingOptions(youngs_moduli=(2e6,), dx=DX, segment_length=0.128, mpd_spike_alpha=6.0, tol=1e-10,
                                max_iterations=1)
    summary = process(manifest(rows), tmp_path / "out", options, quiet=True)
    assert (summary.processed, summary.failed) == (3, 0)
    seg = table(tmp_path / "out", "segments")
    assert (~seg["converged"]).sum() > 0
    assert (seg.filter(~pl.col("converged"))["residual"] > options.tol).all()
    assert (seg.filter(pl.col("converged"))["residual"] <= options.tol).all()
    assert (seg["iterations"] <= 1).all()


# --------------------------------------------------------------------------------------------
# the disk fills up at the worst moments


def fill_disk_on(patch: pytest.MonkeyPatch, where, *, real: bool = False) -> None:
    """Makes every Parquet write (eager or streamed) to a file for which ``where(path)`` holds
    fail as on a full disk: with the OSError(ENOSPC) a Python writer raises, or (``real``) by
    sending the bytes to /dev/full, so that polars meets a real ENOSPC from the kernel and
    raises what it raises then."""
    write, sink = pl.DataFrame.write_parquet, pl.LazyFrame.sink_parquet

    def fail(file):
        if real:
            return "/dev/full"
        raise OSError(errno.ENOSPC, "No space left on device")

    def write_parquet(self, file, *args, **kwargs):
        return write(self, fail(file) if where(Path(file)) else file, *args, **kwargs)

    def sink_parquet(self, path, *args, **kwargs):
        return sink(self, fail(path) if where(Path(path)) else path, *args, **kwargs)

    patch.setattr(pl.DataFrame, "write_parquet", write_parquet)
    patch.setattr(pl.LazyFrame, "sink_parquet", sink_parquet)


def test_full_disk_while_writing_a_run_status_loses_nothing(tmp_path, archive, monkeypatch):
    """The disk fills while run01's status.json (the file that marks a run done) is written:
    ArchiveWriteError; run00 stays done; run01 is not marked done, so the next job redoes it;
    no temporary file is left; the final tables are the reference's."""
    rows, reference = archive
    out = tmp_path / "out"
    original = Path.write_text

    def write_text(self, *args, **kwargs):
        if self.name.startswith(".status.json") and self.parent.name == "run01":
            raise OSError(errno.ENOSPC, "No space left on device")
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", write_text)
    with pytest.raises(ArchiveWriteError, match="No space left"):
        process(manifest(rows), out, OPTIONS, quiet=True)
    monkeypatch.setattr(Path, "write_text", original)
    done = sorted(p.parent.name for p in (out / "runs").glob("*/status.json"))
    # Two runs are in flight: run02 may have finished beside run01 before the job stopped.
    assert done in (["run00"], ["run00", "run02"])
    assert not list(out.rglob("*.tmp"))
    summary = process(manifest(rows), out, OPTIONS, quiet=True)
    assert (summary.processed, summary.skipped) == (3 - len(done), len(done))
    for name in TABLES:
        assert_frame_equal(table(out, name), table(reference, name), check_exact=True)


def test_full_disk_while_writing_the_combined_tables_keeps_the_previous_ones(tmp_path, archive, monkeypatch):
    """A finished job's tables exist; a second job (force) fills the disk while writing the
    combined segments table: ArchiveWriteError, and the previous combined tables are intact
    (atomic rename), every run is still marked done, no temporary file is left."""
    rows, reference = archive
    out = tmp_path / "out"
    process(manifest(rows), out, OPTIONS, quiet=True)
    before = {name: (out / f"{name}.parquet").read_bytes() for name in TABLES}
    with monkeypatch.context() as patch:
        fill_disk_on(patch, lambda file: file.name.startswith(".segments.parquet") and file.parent == out)
        with pytest.raises(ArchiveWriteError, match="No space left"):
            process(manifest(rows), out, OPTIONS, quiet=True, force=True)
    assert {name: (out / f"{name}.parquet").read_bytes() for name in TABLES} == before
    assert len(list((out / "runs").glob("*/status.json"))) == 3
    assert not list(out.rglob("*.tmp"))
    for name in TABLES:
        assert_frame_equal(table(out, name), table(reference, name), check_exact=True)



@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs Linux /dev/full for a real ENOSPC")
@pytest.mark.parametrize("target", ["a run's table", "the combined segments table"])
def test_real_enospc_from_polars_gives_archive_write_error(tmp_path, archive, monkeypatch, target):
    """A real ENOSPC (the write goes to /dev/full) while writing a run's table or the combined
    table: ArchiveWriteError, no temporary file left, finished runs intact."""
    rows, reference = archive
    out = tmp_path / "out"
    if target == "a run's table":
        where = lambda file: file.name.startswith(".bands.parquet") and file.parent.name == "run01"  # noqa: E731
    else:
        where = lambda file: file.name.startswith(".segments.parquet") and file.parent == out  # noqa: E731
    with monkeypatch.context() as patch:
        fill_disk_on(patch, where, real=True)
        # polars' streaming sink reports the failed write in its own words ("Invalid thrift:
        # transport error"), the eager writer as "No space left": both must stop the job.
        with pytest.raises(ArchiveWriteError, match="cannot write .*parquet"):
            process(manifest(rows), out, OPTIONS, quiet=True)
    assert not list(out.rglob("*.tmp"))
    summary = process(manifest(rows), out, OPTIONS, quiet=True)
    assert summary.failed == 0
    for name in TABLES:
        assert_frame_equal(table(out, name), table(reference, name), check_exact=True)
