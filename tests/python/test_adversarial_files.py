"""Hostile and damaged files (issue 29): each is refused as that file's fault, with a clear
ProfileFormatError naming it, before anything is allocated from what the file claims; in a job it
is that run's recorded failure and the other runs go on."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from roadtex.archive import ProcessingOptions, process
from roadtex.errors import InvalidInputError, ProfileFormatError
from roadtex.profiles import read_profile, write_profile
from roadtex.profiles.pavements import synthetic_pavement

DX = 5e-4
pytestmark = pytest.mark.filterwarnings("ignore::roadtex.errors.ErrorBudgetWarning")


def npy_with_header(path: Path, header: str, payload: bytes = b"") -> Path:
    """A version-1.0 .npy file whose header text is ``header`` (padded as numpy pads it)."""
    text = header.encode("latin1")
    text += b" " * (63 - (len(text) + 10) % 64) + b"\n"
    path.write_bytes(b"\x93NUMPY\x01\x00" + len(text).to_bytes(2, "little") + text + payload)
    return path


def huge_claim(path: Path) -> Path:
    return npy_with_header(path, "{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000000,), }",
                           b"\x00" * 80)


def test_a_header_claiming_terabytes_is_refused_before_allocating(tmp_path: Path) -> None:
    bad = huge_claim(tmp_path / "huge.npy")
    assert bad.stat().st_size < 300
    with pytest.raises(ProfileFormatError, match=r"huge\.npy: damaged \.npy: its header claims shape \(1000000000000,\)"):
        read_profile(bad, dx=DX)


def test_a_huge_claim_is_one_runs_failure_and_the_job_goes_on(tmp_path: Path) -> None:
    good = write_profile(synthetic_pavement("dense_asphalt", 0.6, DX, seed=0), tmp_path / "good.parquet")
    bad = huge_claim(tmp_path / "huge.npy")
    rows = pl.DataFrame({"path": [str(bad), str(good)], "run_id": ["huge", "good"], "dx": [DX, None]})
    options = ProcessingOptions(youngs_moduli=(1e7,), dx=DX, segment_length=0.128, tol=1e-6)
    summary = process(rows, tmp_path / "out", options, quiet=True, threads=1)
    assert (summary.processed, summary.failed) == (1, 1)
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet")
    assert errors["run_id"].to_list() == ["huge"]
    assert "header claims shape" in errors["message"][0]


def test_an_unclosed_bracket_in_the_header_is_a_format_error_naming_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "bracket.npy"
    bad.write_bytes(b"\x93NUMPY\x01\x00\x40\x00{'descr': [(" + b" " * 51 + b"\n")
    with pytest.raises(ProfileFormatError, match=r"bracket\.npy: not a readable \.npy array: damaged header"):
        read_profile(bad, dx=DX)


def test_an_npz_saved_as_npy_is_named_as_such(tmp_path: Path) -> None:
    bad = tmp_path / "archive.npy"
    with open(bad, "wb") as handle:
        np.savez(handle, heights=np.zeros(100))
    assert zipfile.is_zipfile(bad)
    with pytest.raises(ProfileFormatError, match=r"archive\.npy: a \.npz archive"):
        read_profile(bad, dx=DX)


def test_a_dx_a_million_times_too_fine_is_refused_before_allocating() -> None:
    profile = synthetic_pavement("dense_asphalt", 0.6, DX, seed=0)
    with pytest.raises(InvalidInputError, match=r"dx = 1e-12 m would resample 1200 readings .* more than 1000 per reading"):
        profile.resample(1e-12)
    assert profile.resample(DX / 100).heights.size == 120_000   # finer, within reason, still works
    with pytest.raises(InvalidInputError, match=r"dx = 1e-12 m is finer than 1e-06 m"):
        ProcessingOptions(dx=1e-12)


def test_messages_quote_a_file_only_in_a_short_escaped_excerpt(tmp_path: Path) -> None:
    secret = "s3cr3t-token-" + "x" * 60
    bad = tmp_path / "notes.csv"
    bad.write_text(f"user,key\nalice,{secret}\nbob,{secret}\n")
    with pytest.raises(ProfileFormatError) as caught:
        read_profile(bad)
    message = str(caught.value)
    assert message.startswith("notes.csv: ") and "line 2 is not a row of 2 numbers: 'alice,s3cr3t-token-xxxxx'..." in message
    assert secret not in message and secret[:30] not in message


def test_a_huge_file_of_nul_bytes_is_refused_from_its_head(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    bad = tmp_path / "zeros.csv"
    with open(bad, "wb") as handle:
        handle.truncate(2 * 1024**3)   # 2 GiB of NUL bytes (sparse: nothing written)
    # the bytes the reader reads, counted (not timed: a loaded machine makes a time a coin toss)
    read: list[int] = []
    opened = Path.open

    class Counted:
        def __init__(self, handle) -> None:
            self.handle = handle

        def read(self, *args):
            data = self.handle.read(*args)
            read.append(len(data))
            return data

        def __enter__(self):
            return self

        def __exit__(self, *exc) -> None:
            self.handle.close()

        def __getattr__(self, name: str):
            return getattr(self.handle, name)

    monkeypatch.setattr(Path, "open", lambda self, *a, **k: Counted(opened(self, *a, **k)))
    with pytest.raises(ProfileFormatError, match=r"zeros\.csv looks like binary data, not a text profile"):
        read_profile(bad)
    assert read and sum(read) <= 64 * 1024   # it read all 2 GiB before (5.9 s, 2.2 GB of memory)


def test_one_corrupt_distance_is_not_taken_for_terabytes_of_missing_rows(tmp_path: Path) -> None:
    # found by fuzzing: a regular file whose last distance is 10^11 steps on was read as a file
    # with rows missing, and listing them asked numpy for 0.8 TB
    heights = synthetic_pavement("dense_asphalt", 0.3, DX, seed=2).heights
    distances = DX * np.arange(heights.size)
    distances[-1] = 5e7
    bad = tmp_path / "jump.csv"
    bad.write_text("distance_m,height_m\n" + "".join(f"{x:.10g},{z:.10g}\n" for x, z in zip(distances, heights)))
    # refused as the jump it is (issue 38: before, read as an uneven file whose mean step was then
    # taken for distances in mm read as m), before anything is allocated for it
    with pytest.raises(ProfileFormatError, match=rf"jump\.csv: the distances jump by .* between readings "
                                                 rf"{heights.size - 1} and {heights.size} by distance"):
        read_profile(bad)


def test_memory_error_while_reading_a_file_is_that_runs_failure(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from roadtex.archive import compute

    good = write_profile(synthetic_pavement("dense_asphalt", 0.6, DX, seed=0), tmp_path / "good.parquet")
    huge = write_profile(synthetic_pavement("dense_asphalt", 0.6, DX, seed=1), tmp_path / "huge.parquet")
    real = compute.read_profile

    def reading(path, **kwargs):
        if Path(path).name == "huge.parquet":
            raise MemoryError("Unable to allocate 7.28 TiB")
        return real(path, **kwargs)

    monkeypatch.setattr(compute, "read_profile", reading)
    rows = pl.DataFrame({"path": [str(huge), str(good)], "run_id": ["huge", "good"]})
    options = ProcessingOptions(youngs_moduli=(1e7,), dx=DX, segment_length=0.128, tol=1e-6, error_budget_db=None)
    summary = process(rows, tmp_path / "out", options, quiet=True, threads=1)
    assert (summary.processed, summary.failed) == (1, 1)
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet")
    assert errors["run_id"].to_list() == ["huge"] and errors["stage"].to_list() == ["read"]
    assert "needs more memory than is free" in errors["message"][0]


def test_a_high_pass_far_longer_than_the_profile_is_refused_not_a_linalg_error() -> None:
    profile = synthetic_pavement("dense_asphalt", 0.6, DX, seed=0)
    with pytest.raises(InvalidInputError, match=r"cutoff_wavelength 1e\+09 m is more than 1e\+07 times dx"):
        profile.highpass(1e9)
    assert np.isfinite(profile.highpass(1e3).heights).all()   # long, but within reach
