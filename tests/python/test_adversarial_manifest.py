"""The manifest and the command line against what a user may hand them (issue 29): colliding file
names, hostile run ids, other encodings, job-wide options refused before any work."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from roadtex.archive import build_manifest
from roadtex.errors import RoadtexWarning

DX = 5e-4


def write_csv(path: Path, seed: int = 0) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    heights = np.random.default_rng(seed).normal(0.0, 5e-4, 400)
    lines = ["distance_m,height_m", *(f"{i * DX:.6f},{z:.8f}" for i, z in enumerate(heights))]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_generated_run_ids_are_made_unique_and_said(tmp_path: Path) -> None:
    folder = tmp_path / "survey"
    for name in ("a/x.csv", "a_x.csv", "x.csv", "b/a/x.csv"):
        write_csv(folder / name)
    with pytest.warns(RoadtexWarning, match=r"2 file\(s\) share a name .*b/a/x\.csv -> b_a_x; x\.csv -> x-2"):
        table = build_manifest(folder)
    ids = dict(zip((Path(p).relative_to(folder.resolve()).as_posix() for p in table["path"]), table["run_id"]))
    assert ids == {"a/x.csv": "x", "a_x.csv": "a_x", "b/a/x.csv": "b_a_x", "x.csv": "x-2"}
