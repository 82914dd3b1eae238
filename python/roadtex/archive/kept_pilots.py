"""The plan kept with the job: each group's pilots saved in the output folder (``OUT/plan/``), so that
a rerun with nothing new, or with runs added to a known group whose pilot already spoke for runs it
never tried (a group of more runs than it reads), does no pilot work.

A kept group is trusted again only when everything its pilots depend on is the same: the options
that change a pilot's answer and the roadtex version (:func:`pilot_key`), the group's name, the runs
it read (still rows of the group, with the same paths) and their files' bytes (SHA-256, checked by
:func:`roadtex.archive.planning.still_valid`), and its own files' checksums (a damaged or edited
record is made again, never trusted).
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import polars as pl

from roadtex._core import __version__
from roadtex.archive.options import ProcessingOptions
from roadtex.archive.plan import GroupPilot
from roadtex.archive.store import file_sha256, write_atomically

#: The folder of the output folder that keeps the plan.
PLAN_FOLDER = "plan"
#: The pilot's error rule (roadtex.budget.estimate): a kept pilot of another rule is made again.
PILOT_RULE = 3
#: The options a pilot's answer depends on (the others change what runs compute, not the pilot).
PILOT_OPTIONS = ("youngs_moduli", "mean_pressure", "poisson", "segment_length", "dx", "tol", "refine",
                 "interpolant", "error_budget_db", "spike_alpha", "max_iterations", "band_kind", "band_method",
                 "allow_implausible", "reader_defaults")


@dataclass(frozen=True)
class KeptGroup:
    """One (device, pavement) group's pilots, failures and sampled runs, as made or as kept.

    Attributes:
        name: the group (:func:`roadtex.archive.reading.group_key`).
        pilots: one per sampling interval among the runs read.
        failed: pilot name -> why it could not run.
        unread: run id -> why the sample could not use it.
        inputs: run id -> (path, digest) of every run the pilots tried, read or found unreadable
            (:func:`roadtex.archive.planning.input_digest`: its file's bytes and reader options).
        study: the pilots' study rows (pilot.parquet).
        members: the runs of the group when its pilots were made.
    """

    name: str
    pilots: tuple[GroupPilot, ...]
    failed: dict[str, str] = field(default_factory=dict)
    unread: dict[str, str] = field(default_factory=dict)
    inputs: dict[str, tuple[str, str]] = field(default_factory=dict)
    study: pl.DataFrame = field(default_factory=pl.DataFrame)
    members: int = 0


def pilot_key(options: ProcessingOptions) -> str:
    """SHA-256 of what a pilot's answer depends on besides its runs: :data:`PILOT_OPTIONS` and the version."""
    chosen = {name: getattr(options, name) for name in PILOT_OPTIONS}
    payload = json.dumps({"options": chosen, "roadtex": __version__, "rule": PILOT_RULE}, sort_keys=True, default=str)
    return hashlib.sha256(payload.encode()).hexdigest()


def group_file(out: Path, name: str) -> Path:
    return out / PLAN_FOLDER / f"{hashlib.sha256(name.encode()).hexdigest()[:20]}.json"


def encoded(value: Any) -> Any:
    """JSON-safe: an infinite error (a band the setting cannot report) as the string "inf"."""
    if isinstance(value, float) and not math.isfinite(value):
        return repr(value)
    if isinstance(value, dict):
        return {str(k): encoded(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [encoded(v) for v in value]
    return value


def decoded_float(value: Any) -> float:
    return float(value)   # "inf", "nan" and numbers alike


def keep_group(out: Path, key: str, group: KeptGroup) -> None:
    """Saves a group's pilots under ``out/plan/`` (its study rows in Parquet beside), with checksums."""
    path = group_file(out, group.name)
    path.parent.mkdir(parents=True, exist_ok=True)
    study_path = path.with_suffix(".parquet")
    write_atomically(study_path, lambda p: group.study.write_parquet(p))
    record = {"pilot_key": key, "group": group.name, "pilots": [encoded(asdict(p)) for p in group.pilots],
              "failed": group.failed, "unread": group.unread,
              "inputs": {run_id: list(pair) for run_id, pair in group.inputs.items()}, "members": group.members,
              "study_sha256": file_sha256(study_path)}
    body = json.dumps(record, sort_keys=True, allow_nan=False)
    payload = {"record": record, "sha256": hashlib.sha256(body.encode()).hexdigest()}
    write_atomically(path, lambda p: p.write_text(json.dumps(payload, indent=1, sort_keys=True, allow_nan=False),
                                                  encoding="utf-8"))


def kept_groups(out: Path, key: str) -> dict[str, KeptGroup]:
    """The groups kept in ``out/plan/`` for ``key`` (:func:`pilot_key`) whose records are intact; a
    record of other options, another version or damaged is ignored (and replaced when its group's
    pilot is made again)."""
    folder = out / PLAN_FOLDER
    found: dict[str, KeptGroup] = {}
    if not folder.is_dir():
        return found
    for path in sorted(folder.glob("*.json")):
        group = read_group(path, key)
        if group is not None and group_file(out, group.name) == path:
            found[group.name] = group
    return found


def read_group(path: Path, key: str) -> KeptGroup | None:
    """A kept group, or None when its record is not for ``key`` or does not match its checksums."""
    try:
        payload = json.loads(path.read_text(encoding="utf-8"))
        record = payload["record"]
        body = json.dumps(record, sort_keys=True, allow_nan=False)
        if hashlib.sha256(body.encode()).hexdigest() != payload["sha256"] or record["pilot_key"] != key:
            return None
        study_path = path.with_suffix(".parquet")
        if file_sha256(study_path) != record["study_sha256"]:
            return None
        pilots = tuple(pilot_from(entry) for entry in record["pilots"])
        return KeptGroup(name=str(record["group"]), pilots=pilots, failed=dict(record["failed"]),
                         unread=dict(record["unread"]),
                         inputs={run_id: (str(pair[0]), str(pair[1])) for run_id, pair in record["inputs"].items()},
                         study=pl.read_parquet(study_path), members=int(record["members"]))
    except (OSError, ValueError, KeyError, TypeError, IndexError, pl.exceptions.PolarsError):
        return None


def pilot_from(entry: dict[str, Any]) -> GroupPilot:
    """A :class:`GroupPilot` from its kept record (band numbers back to ints, "inf" back to floats)."""
    floats = {"spacing", "data_dx", "tol", "worst_error_db", "seconds_per_metre", "finest_seconds_per_metre",
              "work_speedup", "pilot_seconds"}
    values = {name: (decoded_float(value) if name in floats else value) for name, value in entry.items()}
    for name in ("band_error_db", "interpolant_spread_db"):
        values[name] = {int(band): decoded_float(error) for band, error in entry[name].items()}
    values["pilot_runs"] = tuple(entry["pilot_runs"])
    values["refine"] = int(entry["refine"])
    values["within_budget"] = bool(entry["within_budget"])
    return GroupPilot(**values)
