"""A new user's third walk (issue 30): what still tripped a user, each fixed and checked here."""

from __future__ import annotations

from pathlib import Path

import polars as pl

from roadtex.archive import ProcessingOptions, build_manifest, process
from roadtex.cli import main
from roadtex.profiles import write_profile
from roadtex.profiles.pavements import synthetic_pavement

DX = 5e-4
OPTIONS = ProcessingOptions(youngs_moduli=(2e6, 1e7), dx=DX, segment_length=0.128, tol=1e-8, error_budget_db=None)


def survey(folder: Path, runs: int = 2, length: float = 0.3) -> list[Path]:
    """``runs`` synthetic line profiles of ``length`` m written to ``folder`` as CSV."""
    folder.mkdir(parents=True, exist_ok=True)
    return [write_profile(synthetic_pavement("dense_asphalt", length, DX, seed=i), folder / f"run{i:02d}.csv")
            for i in range(runs)]


def test_manifest_skips_a_folder_holding_a_jobs_outputs(tmp_path: Path, capsys) -> None:
    folder = tmp_path / "survey"
    files = survey(folder)
    process(build_manifest(folder), folder / "results", OPTIONS, quiet=True, threads=1)
    assert (folder / "results" / "parameters.json").is_file()
    table = build_manifest(folder)
    assert sorted(Path(p).name for p in table["path"]) == sorted(p.name for p in files)
    # an interrupted job (run folders with status files, no parameters.json yet) is skipped too
    (folder / "results" / "parameters.json").rename(folder / "results" / "kept.json")
    assert build_manifest(folder).height == len(files)
    assert main(["manifest", str(folder), "--out", str(tmp_path / "manifest.csv")]) == 0
    out = capsys.readouterr().out
    assert f"{len(files)} runs" in out and "skipped 1 folder(s) holding a roadtex job's outputs" in out
    assert "results" in out
    assert pl.read_csv(tmp_path / "manifest.csv").height == len(files)
    # the output folder itself given as the survey folder: refused, saying why
    assert main(["manifest", str(folder / "results"), "--out", str(tmp_path / "m2.csv")]) == 2
    assert "holds a roadtex job's outputs" in capsys.readouterr().err
