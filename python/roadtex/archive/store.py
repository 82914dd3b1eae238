"""Atomic output: every file written to a temporary name and renamed into place; run status."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import uuid
from pathlib import Path
from typing import Any, Callable

from roadtex.archive.schemas import METADATA_COLUMNS
from roadtex.errors import ArchiveWriteError

#: The file whose presence marks a run as done (renamed in last).
STATUS_FILE = "status.json"


def file_sha256(path: str | os.PathLike[str]) -> str:
    """SHA-256 of a file's bytes (detects changed inputs whatever their timestamps)."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def write_atomically(path: Path, write: Callable[[Path], None]) -> None:
    temporary = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    try:
        write(temporary)
        with open(temporary, "rb+") as stream:
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except Exception as exc:
        # polars reports a full disk as its own ComputeError ("... os error 28"), not OSError:
        # any failure to write output is a write failure, and stops the job.
        temporary.unlink(missing_ok=True)
        code = exc.errno if isinstance(exc, OSError) else None
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise ArchiveWriteError(code, f"cannot write {path}: {reason}") from exc


def write_json(path: Path, payload: dict[str, Any]) -> None:
    write_atomically(path, lambda p: p.write_text(json.dumps(payload, indent=1, sort_keys=True, default=str), encoding="utf-8"))


def read_status(run_dir: Path) -> dict[str, Any] | None:
    try:
        return json.loads((run_dir / STATUS_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def run_fingerprint(options_fingerprint: str, input_sha256: str, run: dict[str, Any]) -> str:
    metadata = {name: run.get(name) for name in (*METADATA_COLUMNS, "format")}
    payload = json.dumps([options_fingerprint, input_sha256, metadata], sort_keys=True, default=str)
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
        raise ArchiveWriteError(exc.errno, f"output folder {out} is not writable: {exc.strerror or exc}") from exc


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
