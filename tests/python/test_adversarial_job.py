"""The bulk job against faults of its own output and of what it reads back (issue 29): a read-only
file system mid-write, unusable combined tables, corrupt per-run files, manifest order, concurrent
jobs on one folder, job-wide options checked before any work."""

from __future__ import annotations

import errno
from pathlib import Path

import polars as pl
import pytest

from roadtex.archive.store import write_atomically
from roadtex.errors import ArchiveWriteError


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
