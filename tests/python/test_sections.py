"""Issue 32's indicators per section of road: sections.parquet and section_bands.parquet from the bulk
job (sections summing to the run, partial sections said so, energy-averaged band levels), the
texture-profile moments against closed forms, and MPD per section against captif-slp's MPD per
evaluation length on the real CAPTIF files."""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from roadtex.archive import ProcessingOptions, process
from roadtex.archive.sections import section_table
from roadtex.errors import InvalidInputError
from roadtex.profiles import Profile, mpd, read_profile, write_profile
from roadtex.profiles.pavements import synthetic_pavement

REPO = Path(__file__).resolve().parents[2]
PEER_PYTHON = REPO / ".venv-peers" / "bin" / "python"
OPTIONS = ProcessingOptions(youngs_moduli=(2e6, 5e6), segment_length=0.128, tol=1e-8, error_budget_db=None,
                            section_length=1.0)


@pytest.fixture(scope="module")
def job(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 2.35 m run (two whole 1 m sections and a partial one) and a 0.6 m run (shorter than a section)."""
    folder = tmp_path_factory.mktemp("sections")
    write_profile(synthetic_pavement("dense_asphalt", 2.35, 0.5e-3, seed=3), folder / "long.csv")
    write_profile(synthetic_pavement("surface_dressing", 0.6, 0.5e-3, seed=5), folder / "short.csv")
    manifest = folder / "manifest.csv"
    pl.DataFrame({"path": ["long.csv", "short.csv"], "run_id": ["long", "short"]}).write_csv(manifest)
    out = tmp_path_factory.mktemp("out")
    summary = process(manifest, out, OPTIONS, quiet=True)
    assert summary.failed_on_record == 0, pl.read_parquet(out / "errors.parquet")
    return out


def test_sections_tile_the_run_and_sum_to_its_mpd(job: Path) -> None:
    sections = pl.read_parquet(job / "sections.parquet")
    runs = pl.read_parquet(job / "runs.parquet")
    for run_id in ("long", "short"):
        part = sections.filter(pl.col("run_id") == run_id).sort("section")
        run = runs.filter(pl.col("run_id") == run_id).row(0, named=True)
        # contiguous, and every baseline of the run in exactly one section
        np.testing.assert_allclose(part["start"][1:].to_numpy(), part["end"][:-1].to_numpy(), rtol=0, atol=1e-12)
        assert part["baselines"].sum() == run["mpd_baselines"]
        assert part["valid_baselines"].sum() == run["mpd_valid_baselines"]
        assert part["length"].sum() == pytest.approx(0.1 * run["mpd_baselines"], rel=1e-9)
        # the run's MPD is the valid-baseline-weighted mean of its sections' MPDs
        weighted = (part["mpd"].fill_null(0.0) * part["valid_baselines"]).sum() / part["valid_baselines"].sum()
        assert weighted == pytest.approx(run["mpd"], rel=1e-9)
        assert (part["etd"] == part["mpd"] * 1.1).all() and (part["etd_edition"] == "2019").all()
    long = sections.filter(pl.col("run_id") == "long").sort("section")
    assert long.height == 3 and long["partial"].to_list() == [False, False, True]
    assert long["length"][:2].to_list() == pytest.approx([1.0, 1.0]) and long["note"][2].startswith("the run's last")
    short = sections.filter(pl.col("run_id") == "short")
    assert short.height == 1 and short["partial"][0] and "shorter than one 1 m section" in short["note"][0]


def test_section_band_levels_are_energy_averages_of_the_segments_starting_in_them(job: Path) -> None:
    bands = pl.read_parquet(job / "bands.parquet").filter(pl.col("run_id") == "long")
    segments = pl.read_parquet(job / "segments.parquet").filter(pl.col("run_id") == "long")
    sections = pl.read_parquet(job / "sections.parquet").filter(pl.col("run_id") == "long").sort("section")
    section_bands = pl.read_parquet(job / "section_bands.parquet").filter(pl.col("run_id") == "long")
    moduli = sorted(set(section_bands["youngs_modulus"]))
    assert moduli == [2e6, 5e6]
    starts = dict(segments.select("segment", "start").unique().iter_rows())
    for k, (lo, hi) in enumerate(zip(sections["start"], sections["end"])):
        inside = [s for s, x in starts.items() if lo - 1e-3 <= x < hi - 1e-9]
        for e in moduli:
            rows = bands.filter(pl.col("segment").is_in(inside) & (pl.col("youngs_modulus") == e)
                                & pl.col("pressure_level").is_not_null())
            for band, levels in rows.group_by("band").agg(pl.col("pressure_level")).iter_rows():
                got = section_bands.filter((pl.col("section") == k) & (pl.col("youngs_modulus") == e)
                                           & (pl.col("band") == band))
                expected = 10 * math.log10(sum(10 ** (v / 10) for v in levels) / len(levels))
                assert got["pressure_level"][0] == pytest.approx(expected, abs=1e-9)
                assert got["segments"][0] == len(inside)
    # 1 m sections of 0.128 m segments: 8 segments start in each whole section
    assert section_bands.filter(pl.col("section") == 0)["segments"].max() == 8


def cosine(amplitude: float, wavelength: float, length: float, dx: float = 0.5e-3) -> Profile:
    x = dx * (np.arange(int(round(length / dx))) + 0.5)
    return Profile.from_heights(amplitude * np.cos(2 * np.pi * x / wavelength), dx, start=0.5 * dx)


def test_texture_moments_of_a_cosine_are_its_closed_forms() -> None:
    # whole periods in every 100 mm baseline, mirror-symmetric (its line is flat): Rq = A / sqrt 2,
    # Rsk = 0, Rku = 3/2 exactly on the samples; MPD = the sampled crest
    depth = mpd(cosine(1e-3, 10e-3, 2.5), lowpass_wavelength=None)
    table = section_table("c", depth, 1.0)
    assert table.height == 3
    np.testing.assert_allclose(table["rq"].to_numpy(), 1e-3 / math.sqrt(2), rtol=1e-9)
    np.testing.assert_allclose(table["rsk"].to_numpy(), 0.0, atol=1e-9)
    np.testing.assert_allclose(table["rku"].to_numpy(), 1.5, rtol=1e-9)
    np.testing.assert_allclose(table["mpd"].to_numpy(), 1e-3 * math.cos(math.pi * 0.5e-3 / 10e-3), rtol=1e-9)
    assert table["etd_edition"][0] == "2019"
    old = section_table("c", depth, 1.0, etd_edition="1997")
    np.testing.assert_allclose(old["etd"].to_numpy(), 0.2e-3 + 0.8 * table["mpd"].to_numpy(), rtol=1e-12)


def test_a_pulse_train_has_the_skewness_and_kurtosis_of_its_two_levels() -> None:
    # heights 1 mm on a share p = 0.2 of each 10 mm period, 0 elsewhere, pulses centred in the
    # period (each baseline mirror-symmetric, its line flat): a two-level distribution with
    # Rsk = (1 - 2p) / sqrt(p (1 - p)), Rku = (1 - 3 p (1 - p)) / (p (1 - p))
    dx, p = 0.5e-3, 0.2
    x = dx * (np.arange(int(round(1.0 / dx))) + 0.5)
    phase = (x % 10e-3) / 10e-3
    heights = np.where(np.abs(phase - 0.5) < p / 2, 1e-3, 0.0)
    depth = mpd(Profile.from_heights(heights, dx, start=0.5 * dx), lowpass_wavelength=None, spike_alpha=None)
    table = section_table("pulse", depth, 1.0)
    assert table["rsk"][0] == pytest.approx((1 - 2 * p) / math.sqrt(p * (1 - p)), rel=1e-9)
    assert table["rku"][0] == pytest.approx((1 - 3 * p * (1 - p)) / (p * (1 - p)), rel=1e-9)
    assert table["rq"][0] == pytest.approx(1e-3 * math.sqrt(p * (1 - p)), rel=1e-9)


def test_bad_section_settings_are_refused() -> None:
    with pytest.raises(InvalidInputError, match="section_length"):
        dataclasses.replace(OPTIONS, section_length=0.0)
    with pytest.raises(InvalidInputError, match="etd_edition"):
        dataclasses.replace(OPTIONS, etd_edition="2004")


PEER_SCRIPT = """
import json, sys
from captif_slp import Reading
for path in sys.argv[2:]:
    reading = Reading.from_file(path, alpha=6, detect_plates=True, parallel=False, segment_length_mm=100,
                                target_sample_spacing_mm=0.5, evaluation_length_m=float(sys.argv[1]))
    rows = reading.mpd()
    rows = [rows] if isinstance(rows, dict) else rows.to_dict("records")
    print(json.dumps({"file": path, "rows": [{"distance_m": r["distance_m"], "mpd_mm": r["mpd"],
                                              "valid": int(r["valid_segments"])} for r in rows]}))
"""


@pytest.mark.skipif(not PEER_PYTHON.exists(), reason="the captif-slp peer needs its own venv: create it with "
                    "'bash scripts/peer-captif-slp.sh install' (about a minute; it pins numpy < 2)")
def test_mpd_per_section_matches_captif_slp_per_evaluation_length(captif_dir: Path) -> None:
    # captif-slp's continuous mode: evaluation lengths of 0.5 m from the trimmed start, a high-pass
    # instead of each baseline's line, baselines assigned by where they start: our sections with
    # the same settings (alpha 6, plates detected, slope suppression by high-pass)
    files = sorted(captif_dir.glob("*.dat"))
    out = subprocess.run([str(PEER_PYTHON), "-c", PEER_SCRIPT, "0.5", *map(str, files)], capture_output=True,
                         text=True, timeout=300, check=True)
    peers = [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]
    assert len(peers) == len(files)
    compared = 0
    for path, peer in zip(files, peers):
        ours = section_table("r", mpd(read_profile(path), spike_alpha=6, slope_suppression="highpass"), 0.5)
        # captif-slp also keeps a last baseline of >= 90 % of the samples (ours: whole ones only)
        theirs = [row for row in peer["rows"] if row["distance_m"] <= ours["end"].max() - ours["start"][0] + 0.5]
        assert ours.height == len(theirs), path.name
        for mine, row in zip(ours.iter_rows(named=True), theirs):
            assert mine["valid_baselines"] in (row["valid"], row["valid"] - 1), path.name
            # the first section holds the high-pass filter's start transient, which the two settle
            # differently (measured: up to 4.4 %, station 0; every other section within 1.5 %)
            tolerance = 0.05 if mine["section"] == 0 else 0.02
            assert mine["mpd"] == pytest.approx(row["mpd_mm"] * 1e-3, rel=tolerance), (path.name, mine["section"])
            compared += 1
    assert compared == 12


def test_the_report_draws_the_long_runs_along_the_road(job: Path, tmp_path: Path) -> None:
    from roadtex.report import build_report
    from roadtex.report.section_figures import long_runs

    assert long_runs(pl.read_parquet(job / "sections.parquet")) == ["long"]   # "short" has one section
    report = build_report(job, out_dir=tmp_path)
    page = report.html.read_text()
    assert "Indicators along the road" in page and "per section of 1 m" in page
    assert (tmp_path / "figures" / "sections.png").stat().st_size > 1000


PEER_TRACE_SCRIPT = """
import json, sys
import pandas as pd
from captif_slp import Reading
reading = Reading.from_trace(pd.read_csv(sys.argv[2]), alpha=3, segment_length_mm=100, target_sample_spacing_mm=0.5,
                             evaluation_length_m=float(sys.argv[1]))
print(json.dumps([{"mpd_mm": r["mpd"], "valid": int(r["valid_segments"])} for r in reading.mpd().to_dict("records")]))
"""


@pytest.mark.skipif(not PEER_PYTHON.exists(), reason="the captif-slp peer needs its own venv: create it with "
                    "'bash scripts/peer-captif-slp.sh install' (about a minute; it pins numpy < 2)")
def test_mpd_per_section_of_a_long_synthetic_run_matches_captif_slp(tmp_path: Path) -> None:
    # 20 m of dense asphalt at 0.5 mm in 5 m sections, captif-slp's continuous mode (alpha 3,
    # high-pass slope suppression): measured within 0.15 % in every section
    profile = synthetic_pavement("dense_asphalt", 20.0, 0.5e-3, seed=11)
    trace = tmp_path / "long.csv"
    pl.DataFrame({"distance_mm": profile.positions * 1e3, "relative_height_mm": profile.heights * 1e3}).write_csv(trace)
    out = subprocess.run([str(PEER_PYTHON), "-c", PEER_TRACE_SCRIPT, "5", str(trace)], capture_output=True, text=True,
                         timeout=300, check=True)
    theirs = json.loads(out.stdout.strip().splitlines()[-1])
    ours = section_table("long", mpd(profile, slope_suppression="highpass"), 5.0)
    assert ours.height == len(theirs) == 4 and not ours["partial"].any()
    for mine, row in zip(ours.iter_rows(named=True), theirs):
        assert mine["valid_baselines"] == row["valid"] == 50
        assert mine["mpd"] == pytest.approx(row["mpd_mm"] * 1e-3, rel=5e-3)
