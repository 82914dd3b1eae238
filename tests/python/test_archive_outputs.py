"""Issue 14's bulk-job outputs: units in every Parquet file, every band kept with its reason, MPD with
its validity, reader options from the manifest, the CLI's unit checks, one sampling interval, and the
Dask engine's tables bit for bit the local engine's on real data."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import polars as pl
import pytest
from polars.testing import assert_frame_equal

import roadtex
from roadtex.archive import ProcessingOptions, process
from roadtex.archive.schemas import TABLES, units
from roadtex.profiles import write_profile
from roadtex.profiles.pavements import synthetic_pavement

ROADTEX = Path(sys.executable).parent / "roadtex"
OPTIONS = ProcessingOptions(youngs_moduli=(2e6,), segment_length=0.128, tol=1e-8)


@pytest.fixture(scope="module")
def mixed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Two runs of one road at 0.25 and 0.5 mm, one as heights-only npy with its dx in the manifest."""
    folder = tmp_path_factory.mktemp("mixed")
    fine = synthetic_pavement("dense_asphalt", 0.6, 0.25e-3, seed=4)
    write_profile(fine, folder / "fine.csv")
    coarse = fine.resample(0.5e-3)
    np.save(folder / "coarse.npy", coarse.heights)
    manifest = folder / "manifest.csv"
    pl.DataFrame({"path": ["fine.csv", "coarse.npy"], "dx": [None, "0.0005"]}).write_csv(manifest)
    out = tmp_path_factory.mktemp("out")
    summary = process(manifest, out, dataclasses.replace(OPTIONS, error_budget_db=None), quiet=True)
    assert summary.failed_on_record == 0, pl.read_parquet(out / "errors.parquet")
    return folder, out


def test_every_parquet_file_states_the_unit_of_every_numeric_column(mixed) -> None:
    _, out = mixed
    for name, columns in TABLES.items():
        path = out / f"{name}.parquet"
        if not path.exists():
            continue
        stated = json.loads(pl.read_parquet_metadata(path)["units"])
        assert stated == units(columns)
        numeric = [c for c, t in pl.read_parquet_schema(path).items() if t.is_numeric()]
        assert set(numeric) <= set(stated), f"{name}: {set(numeric) - set(stated)} without a unit"


def test_every_band_is_kept_with_reported_and_reason(mixed) -> None:
    _, out = mixed
    bands = pl.read_parquet(out / "bands.parquet")
    table = roadtex.band_table(0.25e-3, 0.128)
    assert set(bands["band"].unique()) == set(table["band"])
    unreported = bands.filter(~pl.col("reported"))
    assert unreported.height > 0 and unreported["reason"].null_count() == 0
    assert bands.filter(pl.col("reported"))["reason"].null_count() == bands["reported"].sum()
    assert not bands.select(pl.col("texture_level", "enveloped_level", "pressure_level").is_nan().any()).row(0)[0]


def test_each_run_is_solved_at_its_own_interval(mixed) -> None:
    """No job-wide grid: the 0.5 mm file is solved on its own readings, not interpolated to 0.25 mm."""
    _, out = mixed
    runs = pl.read_parquet(out / "runs.parquet").sort("file_dx")
    assert runs["file_dx"].to_list() == pytest.approx([0.25e-3, 0.5e-3])
    assert runs["dx_used"].to_list() == runs["file_dx"].to_list()


def test_mpd_carries_its_validity(mixed) -> None:
    _, out = mixed
    runs = pl.read_parquet(out / "runs.parquet")
    assert runs["mpd_valid"].all() and (runs["mpd_valid_baselines"] == runs["mpd_baselines"]).all()
    assert runs["mpd_baselines"].to_list() == [6, 6]
    # segments without a whole valid baseline inside have a null MPD, never NaN
    segments = pl.read_parquet(out / "segments.parquet")
    assert segments["mpd"].is_nan().sum() == 0


def test_cli_refuses_implausible_moduli_and_pressures_naming_the_unit(mixed, tmp_path: Path) -> None:
    folder, _ = mixed
    for flags in (["--moduli", "2.5e6"], ["--pressure", "200000"]):
        done = subprocess.run([str(ROADTEX), "process", str(folder / "manifest.csv"), "--out", str(tmp_path / "o"), *flags],
                              capture_output=True, text=True, timeout=120)
        assert done.returncode == 2 and "MPa" in done.stderr and flags[0] in done.stderr, done.stderr
        assert not (tmp_path / "o" / "segments.parquet").exists()
    version = subprocess.run([str(ROADTEX), "--version"], capture_output=True, text=True, timeout=60)
    assert version.returncode == 0 and version.stdout.strip() == f"roadtex {roadtex.__version__}"


def test_options_refuse_implausible_moduli_from_python() -> None:
    # as strict as the command line (issue 30.6): refused, one message, unless allowed
    with pytest.raises(roadtex.errors.InvalidInputError, match="MPa") as refused:
        ProcessingOptions(youngs_moduli=(2.5,))
    assert "allow_implausible=True" in str(refused.value)


def test_dask_and_local_tables_are_bit_identical_on_real_data(tmp_path: Path, captif_dir: Path) -> None:
    pytest.importorskip("distributed", reason="dask.distributed is a dev requirement; install roadtex[dask]")
    manifest = pl.DataFrame({"path": [str(captif_dir / "20211011_aylesbury_dec_station_1.dat")]})
    options = ProcessingOptions(youngs_moduli=(1e6, 1e7), tol=1e-6)
    process(manifest, tmp_path / "local", options, quiet=True)
    process(manifest, tmp_path / "dask", options, engine="dask", workers=1, quiet=True)
    for name in ("segments", "bands", "runs", "examples"):
        assert_frame_equal(pl.read_parquet(tmp_path / "dask" / f"{name}.parquet"),
                           pl.read_parquet(tmp_path / "local" / f"{name}.parquet"), check_exact=True)


def test_budget_off_with_a_given_dx_and_tol_is_the_plain_pipeline_bit_for_bit(mixed, tmp_path: Path) -> None:
    """--error-budget off --dx --tol: exactly read, clean, condition, segment, contact_many, band_levels."""
    from roadtex.profiles import read_profile
    from roadtex.spectra import band_levels

    folder, _ = mixed
    options = dataclasses.replace(OPTIONS, youngs_moduli=(1e6, 1e7), error_budget_db=None, dx=0.25e-3, tol=1e-6)
    process(pl.DataFrame({"path": [str(folder / "fine.csv")]}), tmp_path / "out", options, quiet=True)
    profile = read_profile(folder / "fine.csv").conditioned(dx=0.25e-3, spike_alpha=options.spike_alpha)
    segments = profile.segments(options.segment_length)
    batch = roadtex.contact_many(segments.heights, 0.25e-3, list(options.youngs_moduli), options.mean_pressure,
                                 tol=1e-6, warm_start=True, raise_on_nonconvergence=False)
    rows = batch.envelope.shape[0] * batch.envelope.shape[1]
    enveloped = band_levels(batch.envelope.reshape(rows, -1), 0.25e-3, periodic=True)
    bands = pl.read_parquet(tmp_path / "out" / "bands.parquet").sort("segment", "youngs_modulus", "band")
    assert bands["level_error_db"].null_count() == bands.height
    got = bands["enveloped_level"].to_numpy().reshape(rows, -1)
    expected = np.where(np.isfinite(enveloped.levels), enveloped.levels, np.nan)
    np.testing.assert_array_equal(got, expected)


def test_build_manifest_lists_opencrg_surfaces_beside_profiles(tmp_path: Path, captif_dir: Path) -> None:
    (tmp_path / "lane.crg").write_text("$CT\nnot read when listing\n$\n", encoding="utf-8")
    (tmp_path / "station.dat").write_bytes((captif_dir / "20211011_aylesbury_dec_station_0.dat").read_bytes())
    table = roadtex.build_manifest(tmp_path)
    assert sorted(Path(p).name for p in table["path"]) == ["lane.crg", "station.dat"]


def run_estimates_are_their_groups(out: Path) -> bool:
    """Asserts that every run's rows state its own group's estimates (worst error, verdict, error
    and interpolant spread per band, sampling_limited where the spread exceeds the budget), not the
    largest over the groups; returns whether some run's estimate is below the largest."""
    plan = json.loads((out / "parameters.json").read_text())["plan"]
    groups = plan["group_errors"]
    assert sorted(g["spacing"] for g in groups.values()) == [0.25e-3, 0.5e-3]
    by_spacing = {g["spacing"]: g for g in groups.values()}
    runs = pl.read_parquet(out / "runs.parquet")
    bands = pl.read_parquet(out / "bands.parquet").filter(pl.col("level_error_db").is_not_null())
    differs = False
    for run in runs.iter_rows(named=True):
        group = by_spacing[float(f"{run['file_dx']:.2g}")]
        assert run["worst_level_error_db"] == group["worst_error_db"]
        assert run["within_budget"] == group["within_budget"]
        mine = bands.filter(pl.col("run_id") == run["run_id"])
        expected = {int(b): e for b, e in group["band_error_db"].items() if np.isfinite(e)}
        # a level at or above its group's median level (of its band and modulus, both kinds) states the
        # group's error; one below states more (its band holds less power than is typical)
        group_rows = bands.filter(pl.col("run_id").is_in(
            [r["run_id"] for r in runs.iter_rows(named=True) if f"{r['file_dx']:.2g}" == f"{run['file_dx']:.2g}"]))
        medians = group_rows.filter(pl.col("reported")).group_by("band", "youngs_modulus").agg(
            pl.col("enveloped_level").median().alias("env_median"), pl.col("pressure_level").median().alias("prs_median"))
        mine = mine.join(medians, on=["band", "youngs_modulus"], how="left").with_columns(
            pl.col("band").replace_strict(expected, default=None).alias("group_error"))
        assert mine["group_error"].null_count() == 0 and mine.height
        assert (mine["level_error_db"] >= mine["group_error"] * (1 - 1e-12)).all()
        typical = mine.filter((pl.col("enveloped_level") >= pl.col("env_median"))
                              & (pl.col("pressure_level") >= pl.col("prs_median")))
        assert typical.height and (typical["level_error_db"] == typical["group_error"]).all()
        stated = dict(mine.group_by("band").agg(pl.col("level_error_db").min()).iter_rows())
        spread = dict(mine.select("band", "interpolant_spread_db").unique().iter_rows())
        assert spread == {b: group["interpolant_spread_db"][str(b)] for b in spread} and len(spread) == len(stated)
        limited = dict(mine.select("band", "sampling_limited").unique().iter_rows())
        assert limited == {b: spread[b] > plan["budget_db"] for b in spread}
        largest = {int(b): e for b, e in plan["band_error_db"].items()}
        differs |= any(stated[b] < largest[b] for b in stated)
    return differs


def test_each_run_carries_its_own_groups_error_estimates(mixed, tmp_path: Path) -> None:
    """Runs at 0.25 and 0.5 mm get a pilot each; every run's rows state its own group's estimates,
    not the largest over the groups (the 0.5 mm group's floor used to be stamped on the 0.25 mm run).
    On the model grid both groups meet the budget, each with its own k (the 0.5 mm group refined; the
    0.25 mm one may meet it on its own readings, as it does on the monotone cubic road since 0.5.0);
    each run is solved on its own readings and its own group's model grid."""
    folder, _ = mixed
    out = tmp_path / "budget"
    with warnings.catch_warnings():
        warnings.simplefilter("error", roadtex.errors.ErrorBudgetWarning)
        summary = process(folder / "manifest.csv", out, OPTIONS, quiet=True)
    assert summary.failed_on_record == 0
    plan = json.loads((out / "parameters.json").read_text())["plan"]
    assert plan["within_budget"] is True and all(g["within_budget"] for g in plan["group_errors"].values())
    runs = pl.read_parquet(out / "runs.parquet")
    groups = {g["spacing"]: g for g in plan["group_errors"].values()}
    for run in runs.iter_rows(named=True):
        group = groups[float(f"{run['file_dx']:.2g}")]
        assert run["refine"] == group["refine"] and run["tol_used"] == group["tol"]
        assert run["dx_used"] == run["file_dx"] and run["model_dx"] == pytest.approx(run["file_dx"] / group["refine"])
    assert groups[0.5e-3]["refine"] > 1 and groups[0.5e-3]["refine"] > groups[0.25e-3]["refine"]
    assert run_estimates_are_their_groups(out), "every run got the largest estimate of any group"


def test_a_group_that_misses_the_budget_is_warned_and_its_runs_say_so(mixed, tmp_path: Path) -> None:
    """Forced onto the data's own grid (refine 1), the 0.5 mm group misses the budget: the warning
    names it, the runs are solved at k = 1, and each run still carries its own group's estimates and
    verdict."""
    folder, _ = mixed
    out = tmp_path / "forced"
    with pytest.warns(roadtex.errors.ErrorBudgetWarning, match="@ 0.5 mm"):
        summary = process(folder / "manifest.csv", out, dataclasses.replace(OPTIONS, refine=1), quiet=True)
    assert summary.failed_on_record == 0
    plan = json.loads((out / "parameters.json").read_text())["plan"]
    assert plan["within_budget"] is False
    assert {g["spacing"]: g["within_budget"] for g in plan["group_errors"].values()}[0.5e-3] is False
    assert {g["refine"] for g in plan["group_errors"].values()} == {1}
    runs = pl.read_parquet(out / "runs.parquet")
    assert runs["refine"].to_list() == [1] * runs.height and runs["model_dx"].to_list() == runs["dx_used"].to_list()
    run_estimates_are_their_groups(out)


def test_the_pilot_skips_runs_the_job_refuses_for_their_units(mixed, tmp_path: Path) -> None:
    """A file of heights in mm read as micrometres is refused by the job; the pilot must not measure
    it either (it used to, and its warnings named no file)."""
    folder, _ = mixed
    fine = roadtex.read_profile(folder / "fine.csv")
    np.savetxt(tmp_path / "um.csv", np.column_stack([fine.positions, fine.heights * 1e3]), delimiter=",",
               header="distance (m),height (um)", comments="")  # the heights are mm: 1000 times too small
    (tmp_path / "fine.csv").write_bytes((folder / "fine.csv").read_bytes())
    manifest = tmp_path / "manifest.csv"
    pl.DataFrame({"path": ["fine.csv", "um.csv"]}).write_csv(manifest)
    out = tmp_path / "out"
    summary = process(manifest, out, OPTIONS, quiet=True)
    errors = pl.read_parquet(out / "errors.parquet")
    assert summary.failed_on_record == 1 and "implausibly small" in errors["message"][0], errors
    plan = json.loads((out / "parameters.json").read_text())["plan"]
    piloted = [run for runs in plan["groups"].values() for run in runs]
    assert piloted == ["fine"], plan["groups"]


def test_a_coarser_file_reports_only_the_bands_its_own_sampling_resolves(mixed) -> None:
    """The 0.5 mm file, solved on its own readings, reports no band below 2.5 x 0.5 mm (ISO
    13473-4's 2.5 points per centre wavelength); the 0.25 mm file of the same road reports them."""
    _, out = mixed
    bands = pl.read_parquet(out / "bands.parquet").filter(pl.col("segment") == 0)
    fine = bands.filter(pl.col("run_id") == "fine").sort("band")
    coarse = bands.filter(pl.col("run_id") == "coarse").sort("band")
    # Independent of the code under test: ISO 13473-4's 2.5 points per centre wavelength.
    assert not coarse.filter(pl.col("centre_wavelength") < 2.5 * 0.5e-3 * (1 - 1e-9))["reported"].any()
    assert fine.filter((pl.col("centre_wavelength") < 2.5 * 0.5e-3 * (1 - 1e-9))
                       & (pl.col("centre_wavelength") >= 2.5 * 0.25e-3))["reported"].sum() >= 2
