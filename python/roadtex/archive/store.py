"""Atomic output: every file written to a temporary name and renamed into place; run status."""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import shutil
import socket
import sys
import time
import uuid
from pathlib import Path
from typing import IO, Any, Callable, Iterator

from roadtex.archive.schemas import METADATA_COLUMNS
from roadtex.errors import ArchiveWriteError, OutputInUseError

#: The file whose presence marks a run as done (renamed in last).
STATUS_FILE = "status.json"


def file_sha256(path: str | os.PathLike[str]) -> str:
    """SHA-256 of a file's bytes (detects changed inputs whatever their timestamps).

    Raises:
        OSError: ``path`` is not a regular file (a folder, a device or a pipe: /dev/zero never ends).
    """
    if not Path(path).is_file():
        raise OSError(f"not a regular file: {path}")
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def checksums(folder: Path, names: list[str]) -> dict[str, str]:
    """SHA-256 of each named file of ``folder`` just written, recorded so that what the job wrote is
    verified before it is trusted again (a rerun, the report)."""
    return {name: file_sha256(folder / name) for name in names}


def damaged_outputs(run_dir: Path, status: dict[str, Any]) -> list[str]:
    """The output files of a finished run (``status`` state "ok") whose bytes no longer match the
    checksums its status recorded, or are gone; all of them when the status recorded none."""
    if status.get("state") != "ok":
        return []
    recorded = status.get("checksums")
    if not isinstance(recorded, dict) or not recorded:
        return ["(no checksums recorded)"]
    damaged = []
    for name, digest in recorded.items():
        try:
            if file_sha256(run_dir / name) != digest:
                damaged.append(name)
        except OSError:
            damaged.append(name)
    return damaged


def write_atomically(path: Path, write: Callable[[Path], None]) -> None:
    temporary = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    try:
        write(temporary)
        with open(temporary, "rb+") as stream:
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except BaseException as exc:
        try:
            temporary.unlink(missing_ok=True)
            cleanup_note = ""
        except OSError as cleanup:
            # a file system turned read-only refuses the cleanup too: the write's error is the one to report
            cleanup_note = f" (and its temporary file {temporary.name} could not be removed: {cleanup.strerror or cleanup})"
        if not isinstance(exc, Exception):   # Ctrl-C while writing: no temporary left behind, and it stops
            raise
        # polars reports a full disk as its own ComputeError ("... os error 28"), not OSError:
        # any failure to write output is a write failure, and stops the job.
        code = exc.errno if isinstance(exc, OSError) else None
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise write_error(code, f"cannot write {path}: {reason}{cleanup_note}") from exc


def write_error(code: int | None, message: str) -> ArchiveWriteError:
    """An ArchiveWriteError with ``code`` as its errno when there is one (OSError's two-argument
    form prints "[Errno None]" before the message otherwise)."""
    return ArchiveWriteError(code, message) if code is not None else ArchiveWriteError(message)


def write_json(path: Path, payload: dict[str, Any]) -> None:
    """Strict JSON (no Infinity/NaN, which JSON has not): a non-finite number is written as null, and
    the top-level ``non_finite`` says what it was, by its path ("plan.worst_error_db": "inf")."""
    found: dict[str, str] = {}
    strict = finite_json(payload, "", found)
    text = json.dumps({**strict, "non_finite": found} if found else strict, indent=1, sort_keys=True, default=str,
                      allow_nan=False)
    write_atomically(path, lambda p: p.write_text(text, encoding="utf-8"))


def finite_json(value: Any, path: str, found: dict[str, str]) -> Any:
    """``value`` with every non-finite float (in dicts, lists, tuples) None, its path and value in ``found``."""
    if isinstance(value, float) and not math.isfinite(value):
        found[path] = str(value)
        return None
    if isinstance(value, dict):
        return {k: finite_json(v, f"{path}.{k}" if path else str(k), found) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_json(v, f"{path}[{i}]", found) for i, v in enumerate(value)]
    return value


def read_status(run_dir: Path) -> dict[str, Any] | None:
    try:
        return json.loads((run_dir / STATUS_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def run_fingerprint(options_fingerprint: str, input_sha256: str, run: dict[str, Any],
                    reading: dict[str, Any], solved_as: dict[str, Any] | None) -> str:
    """SHA-256 of what a run's results depend on, and nothing else: the user's options (with the
    roadtex version), the input file's bytes, the run's metadata and reader options (``reading``,
    the manifest's columns over the job's defaults) and its plan entry (``solved_as``:
    :meth:`roadtex.archive.plan.RunPlan.solved_as`; None for a run that failed before its file's
    interval was known)."""
    metadata = {name: run.get(name) for name in (*METADATA_COLUMNS, "format")}
    payload = json.dumps([options_fingerprint, input_sha256, metadata, reading, solved_as], sort_keys=True, default=str)
    return hashlib.sha256(payload.encode()).hexdigest()


def file_size(path: str) -> int:
    try:
        return os.path.getsize(path)
    except OSError:
        return 0


def check_writable(out: Path) -> None:
    try:
        (out / "runs").mkdir(parents=True, exist_ok=True)
        probe = out / f".write-probe-{uuid.uuid4().hex}"
        probe.write_bytes(b"roadtex")
        probe.unlink()
    except OSError as exc:
        raise write_error(exc.errno, f"output folder {out} is not writable: {exc.strerror or exc}") from exc


#: The output folder's lock file: held (flock) by the job writing the folder, naming it.
LOCK_FILE = ".roadtex.lock"


#: Where the Windows lock sits in the lock file: one byte far past the holder's description, so that
#: a second job can still read who holds the folder (Windows byte locks are mandatory).
WINDOWS_LOCK_OFFSET = 1 << 20


def lock_exclusively(handle: IO[str]) -> None:
    """The kernel's exclusive lock on ``handle``'s file, without waiting (OSError when held):
    ``flock`` on POSIX, ``msvcrt.locking`` of one byte on Windows; either is released when its
    holder ends, however it ends."""
    if sys.platform == "win32":
        import msvcrt

        position = handle.tell()
        handle.seek(WINDOWS_LOCK_OFFSET)
        try:
            msvcrt.locking(handle.fileno(), msvcrt.LK_NBLCK, 1)
        finally:
            handle.seek(position)
    else:
        import fcntl  # portable: POSIX branch (msvcrt on Windows)

        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)


def unlock(handle: IO[str]) -> None:
    if sys.platform == "win32":
        import msvcrt

        handle.seek(WINDOWS_LOCK_OFFSET)
        msvcrt.locking(handle.fileno(), msvcrt.LK_UNLCK, 1)
    else:
        import fcntl  # portable: POSIX branch (msvcrt on Windows)

        fcntl.flock(handle, fcntl.LOCK_UN)


@contextlib.contextmanager
def job_lock(out: Path) -> Iterator[None]:
    """Holds ``out``'s lock for the duration of a job: a second job on the folder is refused,
    naming the holder (pid, host, start time). The lock is the kernel's (:func:`lock_exclusively`), released
    when its holder ends however it ends, so a job killed (kill -9) leaves none: the next takes
    the folder over.

    Raises:
        OutputInUseError: another job holds the folder.
    """
    path = out / LOCK_FILE
    try:
        handle = open(path, "a+", encoding="utf-8")
    except OSError as exc:
        raise write_error(exc.errno, f"cannot lock output folder {out}: {exc.strerror or exc}") from exc
    with handle:
        try:
            lock_exclusively(handle)
        except OSError:
            handle.seek(0)
            holder = handle.read(500).strip() or "an unnamed process"
            raise OutputInUseError(f"output folder {out} is in use by another roadtex job ({holder}); wait for it "
                                   "to finish, or give this job another --out") from None
        handle.seek(0)
        handle.truncate()
        handle.write(f"pid {os.getpid()} on {socket.gethostname()}, started "
                      f"{time.strftime('%Y-%m-%d %H:%M:%S %Z', time.localtime())}")
        handle.flush()
        try:
            yield
        finally:
            handle.seek(0)
            handle.truncate()
            unlock(handle)


def remove_stale_temporaries(out: Path) -> None:
    """Deletes the temporary files of a job that was killed while writing (never complete outputs)."""
    for temporary in [*out.glob(".*.tmp"), *(out / "runs").glob("*/.*.tmp")]:
        temporary.unlink(missing_ok=True)


def remove_outputs(out_dir: str | os.PathLike[str]) -> None:
    """Deletes a job's outputs (the per-run folders and the combined tables)."""
    out = Path(out_dir)
    shutil.rmtree(out / "runs", ignore_errors=True)
    for name in ("segments", "bands", "runs", "errors", "examples", "edge_effect", "surface_examples"):
        (out / f"{name}.parquet").unlink(missing_ok=True)
    (out / "parameters.json").unlink(missing_ok=True)
