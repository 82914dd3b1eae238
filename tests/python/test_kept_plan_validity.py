"""When the plan kept in a job's folder (OUT/plan/) is trusted again (an adversarial hunt, 0.5.15):
only while every run its pilot tried is the same file read the same way, and the group still holds
runs it never tried exactly when it did; ``--force`` makes it again. Otherwise a folder's tables
would depend on its history: a fresh job on the same manifest is the reference."""

import json
import warnings
from pathlib import Path

import numpy as np
import polars as pl
from polars.testing import assert_frame_equal

import roadtex
from roadtex.archive import ProcessingOptions, process

OPTIONS = ProcessingOptions(youngs_moduli=(2e6, 5e6))


def write_runs(folder: Path, count: int) -> list[dict]:
    rows = []
    for i in range(count):
        path = folder / f"r{i}.csv"
        roadtex.write_profile(roadtex.synthetic_pavement("dense_asphalt", 1.5, 1e-3, seed=40 + i), path)
        rows.append({"path": str(path), "run_id": f"r{i}", "pavement": "dense_asphalt", "device": "syn"})
    return rows


def job(rows: list[dict], out: Path, **kwargs) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        process(pl.DataFrame(rows), out, OPTIONS, quiet=True, **kwargs)
    return json.loads((out / "parameters.json").read_text())["plan"]


def same_tables(a: Path, b: Path) -> None:
    for name in ("runs", "bands"):
        left, right = (pl.read_parquet(d / f"{name}.parquet").drop("path", strict=False) for d in (a, b))
        assert_frame_equal(left, right)


def test_a_group_that_loses_its_untried_runs_is_piloted_again(tmp_path: Path) -> None:
    rows = write_runs(tmp_path, 4)              # the pilot reads three of four
    plan = job(rows, tmp_path / "out")
    read = {run for group in plan["group_errors"].values() for run in group["pilot_runs"]}
    assert len(read) == 3
    remaining = [row for row in rows if row["run_id"] in read]   # the one it never tried taken out
    plan = job(remaining, tmp_path / "out")     # its runs unchanged, but no run of the group is untried now
    assert not plan.get("reused_pilots")
    job(remaining, tmp_path / "fresh")
    same_tables(tmp_path / "out", tmp_path / "fresh")


def test_a_mended_file_the_pilot_could_not_read_makes_it_again(tmp_path: Path) -> None:
    rows = write_runs(tmp_path, 3)
    good = Path(rows[1]["path"]).read_bytes()
    Path(rows[1]["path"]).write_text("")        # unreadable: the pilot notes it and reads the others
    plan = job(rows, tmp_path / "out")
    assert "r1" in plan["unread_runs"]
    Path(rows[1]["path"]).write_bytes(good)     # mended
    plan = job(rows, tmp_path / "out")
    assert not plan.get("reused_pilots") and "r1" not in plan.get("unread_runs", {})
    job(rows, tmp_path / "fresh")
    same_tables(tmp_path / "out", tmp_path / "fresh")


def test_a_row_s_reader_options_are_part_of_what_the_pilot_read(tmp_path: Path) -> None:
    rows = write_runs(tmp_path, 3)
    job(rows, tmp_path / "out")
    assert job(rows, tmp_path / "out").get("reused_pilots")          # nothing changed: kept
    changed = [{**row, "start": 10.0} for row in rows]                # the rows say where the runs start
    assert not job(changed, tmp_path / "out").get("reused_pilots")


def test_force_makes_the_pilots_again(tmp_path: Path) -> None:
    rows = write_runs(tmp_path, 3)
    job(rows, tmp_path / "out")
    assert not job(rows, tmp_path / "out", force=True).get("reused_pilots")
    assert np.isfinite(json.loads((tmp_path / "out" / "parameters.json").read_text())["plan"]["pilot_seconds"])
