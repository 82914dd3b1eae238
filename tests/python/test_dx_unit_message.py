"""A heights-only file's dx is in metres whatever its distance_unit says: a manifest's dx 0.5 with
distance_unit mm (0.5 mm meant) is refused, and the refusal says what the mm given means and the
dx it meant (before: it never mentioned the mm)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl

from roadtex.archive import ProcessingOptions, process


def test_a_dx_refused_with_distance_unit_mm_says_what_the_mm_means(tmp_path: Path) -> None:
    heights = np.random.default_rng(0).normal(0.0, 0.5, 4000)   # mm
    (tmp_path / "h.csv").write_text("height (mm)\n" + "".join(f"{z:.4f}\n" for z in heights))
    rows = pl.DataFrame({"path": [str(tmp_path / "h.csv")], "run_id": ["h"], "dx": [0.5], "distance_unit": ["mm"]})
    options = ProcessingOptions(youngs_moduli=(2e6,), error_budget_db=None, segment_length=0.25)
    summary = process(rows, tmp_path / "out", options, quiet=True, threads=1)
    assert (summary.processed, summary.failed) == (0, 1)
    message = pl.read_parquet(tmp_path / "out" / "errors.parquet")["message"][0]
    assert "The interval dx = 0.5 given for it (manifest column dx, --input-dx) must be in metres" in message
    assert ("The distance_unit 'mm' given with it is the unit of a file's distances, not of dx (in metres whatever "
            "distance_unit says): 0.5 mm is dx 0.0005.") in message


def test_the_note_is_said_only_for_a_unit_other_than_metres() -> None:
    from roadtex.archive.compute import dx_unit_note

    assert dx_unit_note(0.5, "m") == "" and dx_unit_note(0.5, None) == "" and dx_unit_note(0.5, "furlong") == ""
    assert dx_unit_note(500, "um").endswith("500 um is dx 0.0005.")
