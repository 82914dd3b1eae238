"""No level from a road nobody measured (issue 38): a segment, tile or section whose readings are
mostly drop-outs is reported as having no level, with the reason, and counts in no mean; the
error budget's pilot never measures its errors on one."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex import ProcessingOptions, process
from roadtex.errors import RoadtexWarning
from roadtex.profiles.coverage import MAX_MISSING_SHARE

DX = 0.5e-3
OPTIONS = ProcessingOptions(youngs_moduli=(2e6,), segment_length=0.25, section_length=1.0)
#: A band level no measured road gives (a straight line filled over a gap gives -270 to -300 dB).
NO_ROAD_DB = -150.0


def run_with_gap(tmp_path: Path, length: float, gap: tuple[float, float], name: str = "gappy") -> Path:
    profile = roadtex.synthetic_pavement("dense_asphalt", length, DX, seed=5)
    heights = profile.heights.copy()
    heights[(profile.positions >= gap[0]) & (profile.positions < gap[1])] = np.nan
    path = roadtex.write_profile(roadtex.Profile.from_heights(heights, DX), tmp_path / f"{name}.parquet")
    manifest = tmp_path / f"{name}.csv"
    pl.DataFrame({"run_id": [name], "path": [str(path)]}).write_csv(manifest)
    return manifest


def processed(manifest: Path, out: Path) -> dict[str, pl.DataFrame]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RoadtexWarning)
        summary = process(manifest, out, OPTIONS, quiet=True, threads=1)
    assert summary.failed == 0 and summary.processed == 1
    return {name: pl.read_parquet(out / f"{name}.parquet") for name in ("segments", "bands", "runs", "sections",
                                                                        "section_bands")}


@pytest.mark.parametrize("gap", [(3.0, 6.0), (2.0, 2.6)], ids=["last half", "0.6 m in the middle"])
def test_segments_of_a_gap_have_no_level_and_the_rest_keep_theirs(tmp_path: Path, gap: tuple[float, float]) -> None:
    tables = processed(run_with_gap(tmp_path, 6.0, gap), tmp_path / "out")
    segments, bands = tables["segments"], tables["bands"]
    # independent of the code: a segment [start, end) lying mostly inside the gap
    inside = (np.minimum(segments["end"], gap[1]) - np.maximum(segments["start"], gap[0])).clip(0) / OPTIONS.segment_length
    unmeasured = segments.filter(pl.Series(inside > MAX_MISSING_SHARE + 0.01))
    measured = segments.filter(pl.Series(inside == 0))
    assert unmeasured.height >= 1 and measured.height >= 1
    assert unmeasured["no_level_reason"].str.contains("readings are missing").all()
    assert unmeasured["contact_fraction"].is_null().all()                 # not the 1.0 of the rubber on a line
    assert measured["no_level_reason"].is_null().all() and measured["contact_fraction"].is_not_null().all()
    levels = bands.select("texture_level", "enveloped_level", "pressure_level").to_numpy()
    finite = levels[np.isfinite(levels)]
    assert finite.size and finite.min() > NO_ROAD_DB, finite.min()        # no level of a road nobody measured
    gap_rows = bands.join(unmeasured.select("segment"), on="segment")
    assert not gap_rows["reported"].any() and gap_rows["enveloped_level"].is_null().all()
    assert gap_rows["reason"].str.contains("readings are missing").all()
    # the error statement survives the gap: the pilot chose measured segments
    run = tables["runs"].row(0, named=True)
    assert run["worst_level_error_db"] is not None and np.isfinite(run["worst_level_error_db"])
    assert bands.filter(pl.col("reported"))["level_error_db"].is_not_null().all()


def test_a_section_in_a_gap_has_no_band_level(tmp_path: Path) -> None:
    tables = processed(run_with_gap(tmp_path, 6.0, (3.0, 6.0)), tmp_path / "out")
    section_bands = tables["section_bands"]
    level_columns = [c for c in section_bands.columns if c.endswith("_level")]
    assert level_columns
    values = section_bands.select(level_columns).to_numpy().astype(float)
    assert np.nanmin(values) > NO_ROAD_DB
    sections = tables["sections"]
    last = sections.filter(pl.col("start") >= 3.0)
    assert last.height >= 2 and last["mpd"].is_null().all()


def test_the_pilot_never_measures_on_filled_segments(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import roadtex.budget.study as study

    seen: list[float] = []
    real = study.segments_of

    def watched(cleaned, dx, length):   # type: ignore[no-untyped-def]
        heights, starts, used = real(cleaned, dx, length)
        seen.extend(start for _, start in starts)
        return heights, starts, used

    monkeypatch.setattr(study, "segments_of", watched)
    processed(run_with_gap(tmp_path, 6.0, (1.0, 6.0)), tmp_path / "out")
    assert seen and max(seen) < 1.0   # every candidate segment lies in the measured first metre
    plan = json.loads((tmp_path / "out" / "parameters.json").read_text())["plan"]
    assert plan["worst_error_db"] is not None


def test_a_surface_tile_whose_columns_are_blanked_has_no_level(tmp_path: Path) -> None:
    surface = roadtex.synthetic_surface("dense_asphalt", length=0.6, width=0.02, dx=1e-3, seed=2)
    heights = surface.heights.copy()
    heights[:, 400:] = np.nan        # the scanner's mask blanks the last 0.2 m
    path = tmp_path / "s.npy"
    np.save(path, heights)
    manifest = tmp_path / "m.csv"
    pl.DataFrame({"run_id": ["s"], "path": [str(path)], "format": ["surface"], "dx": [1e-3],
                  "dy": [surface.dy]}).write_csv(manifest)
    options = ProcessingOptions(youngs_moduli=(2e6,), segment_length=0.2, error_budget_db=None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RoadtexWarning)
        assert process(manifest, tmp_path / "out", options, quiet=True, threads=1).failed == 0
    bands = pl.read_parquet(tmp_path / "out" / "bands.parquet")
    segments = pl.read_parquet(tmp_path / "out" / "segments.parquet")
    levels = bands.select("texture_level", "enveloped_level", "pressure_level").to_numpy().astype(float)
    assert np.nanmin(levels) > NO_ROAD_DB
    blanked = segments.filter(pl.col("start") >= 0.4 - 1e-9)
    assert blanked.height and blanked["no_level_reason"].is_not_null().all()
    assert segments.filter(pl.col("end") <= 0.4 + 1e-9)["no_level_reason"].is_null().all()
