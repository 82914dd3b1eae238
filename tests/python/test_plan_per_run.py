"""The plan per run (issue 37): each run solved on its own readings, whatever company it keeps; the
user's options left as given; the plan kept in the output folder and reused by a rerun."""

from __future__ import annotations

import dataclasses
import json
import warnings
from pathlib import Path

import polars as pl
import pytest
from polars.testing import assert_frame_equal

import roadtex
import roadtex._core
import roadtex.archive.planning as planning
from roadtex import ProcessingOptions, process
from roadtex.archive.plan import JobPlan, RunPlan
from roadtex.errors import ErrorBudgetWarning

#: Two moduli (each solved from its neighbour's answer), the default budget, segments and pressure.
OPTIONS = ProcessingOptions(youngs_moduli=(2e6, 1e7))


def averaged(path: Path, dx: float, out: Path) -> Path:
    """A CAPTIF file as a coarser profilometer would have recorded it: its readings interval-averaged
    to ``dx`` (ISO 13473-1's resampling), drop-outs left as they are, written as Parquet."""
    return roadtex.write_profile(roadtex.read_profile(path).resample(dx), out)


def manifest(rows: list[tuple[str, Path]], path: Path) -> Path:
    pl.DataFrame({"run_id": [r for r, _ in rows], "path": [str(p) for _, p in rows]}).write_csv(path)
    return path


def job(manifest_path: Path, out: Path, options: ProcessingOptions = OPTIONS) -> roadtex.archive.ProcessSummary:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ErrorBudgetWarning)
        return process(manifest_path, out, options, quiet=True, threads=1)


@pytest.fixture(scope="module")
def mixed(captif_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, Path], Path]:
    """An archive mixing three samplings of real road texture: CAPTIF station 0 as measured
    (0.0375 mm), the same averaged to 0.5 mm, and station 10 averaged to 1 mm; processed as one job."""
    folder = tmp_path_factory.mktemp("mixed")
    files = {"fine": captif_dir / "20211011_aylesbury_dec_station_0.dat",
             "half": averaged(captif_dir / "20211011_aylesbury_dec_station_0.dat", 0.5e-3, folder / "half.parquet"),
             "one": averaged(captif_dir / "20211011_aylesbury_dec_station_10.dat", 1e-3, folder / "one.parquet")}
    summary = job(manifest(list(files.items()), folder / "manifest.csv"), folder / "out")
    assert summary.processed == 3 and summary.failed == 0
    return files, folder / "out"


@pytest.mark.parametrize("run_id", ["fine", "half", "one"])
def test_a_run_of_a_mixed_archive_gets_the_tables_of_its_own_single_run_job(mixed, run_id: str,
                                                                             tmp_path: Path) -> None:
    files, out = mixed
    alone = tmp_path / "alone"
    assert job(manifest([(run_id, files[run_id])], tmp_path / "manifest.csv"), alone).processed == 1
    for table in ("segments", "bands", "runs", "sections", "section_bands"):
        together = pl.read_parquet(out / f"{table}.parquet").filter(pl.col("run_id") == run_id)
        assert together.height > 0, table
        assert_frame_equal(together, pl.read_parquet(alone / f"{table}.parquet"))   # bit for bit
    run = pl.read_parquet(out / "runs.parquet").filter(pl.col("run_id") == run_id).row(0, named=True)
    # solved on its own readings: at its own interval (or coarser), never on a finer data grid
    assert run["dx_used"] >= run["file_dx"] * (1 - 1e-12)
    assert run["error_source"].startswith("the pilot of its group") and run["worst_level_error_db"] is not None


def test_each_sampling_of_a_mixed_archive_has_its_own_pilot(mixed) -> None:
    _, out = mixed
    plan = json.loads((out / "parameters.json").read_text())["plan"]
    # a pilot per sampling (each group's interval to two significant digits: 0.0375 mm is 0.037)
    assert sorted(g["spacing"] * 1e3 for g in plan["group_errors"].values()) == pytest.approx([0.037, 0.5, 1.0])
    runs = pl.read_parquet(out / "runs.parquet")
    assert runs.n_unique("dx_used") == 3   # three intervals in one job: no job-wide grid


def test_process_leaves_its_options_as_given_and_they_hold_no_plan(tmp_path: Path) -> None:
    names = {f.name for f in dataclasses.fields(ProcessingOptions)}
    assert not names & {"tol_from_budget", "refine_from_budget", "group_model_dx"}
    options = ProcessingOptions(youngs_moduli=(2e6,), segment_length=0.128)
    before = (dataclasses.asdict(options), options.fingerprint())
    profile = roadtex.synthetic_pavement("dense_asphalt", 0.3, 0.5e-3, seed=3)
    path = roadtex.write_profile(profile, tmp_path / "p.parquet")
    job(manifest([("p", path)], tmp_path / "m.csv"), tmp_path / "out", options)
    assert (dataclasses.asdict(options), options.fingerprint()) == before
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.tol = 1e-3  # type: ignore[misc]


def test_a_line_run_s_entry_is_its_own_interval_or_coarser_never_finer() -> None:
    options = ProcessingOptions(dx=0.5e-3, error_budget_db=None)
    plan = JobPlan.given(options)
    run = {"run_id": "r", "path": "r.csv"}
    assert plan.line_entry(run, 0.25e-3).data_dx == 0.5e-3    # averaged down to the dx asked for
    assert plan.line_entry(run, 1e-3).data_dx == 1e-3         # a coarser file keeps its own readings
    assert isinstance(plan.line_entry(run, 1e-3), RunPlan) and plan.line_entry(run, 1e-3).refine == 1


def forbid_solves(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every solver of the Rust core, and the pilot, raise if called."""
    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("a solver was called")
    for name in ("solve", "solve_many", "solve_surface", "solve_surface_many", "clapp", "von_meier"):
        monkeypatch.setattr(roadtex._core, name, refuse)
    monkeypatch.setattr(planning, "choose_setting", refuse)


@pytest.fixture()
def small_archive(tmp_path: Path) -> tuple[Path, Path, list[tuple[str, Path]]]:
    rows = [(f"r{i}", roadtex.write_profile(roadtex.synthetic_pavement("dense_asphalt", 0.6, 0.5e-3, seed=i),
                                            tmp_path / f"r{i}.parquet")) for i in range(2)]
    return tmp_path / "manifest.csv", tmp_path / "out", rows


SMALL = ProcessingOptions(youngs_moduli=(2e6,), segment_length=0.128)


def test_a_rerun_with_nothing_new_calls_no_solver_and_no_pilot(small_archive, monkeypatch: pytest.MonkeyPatch) -> None:
    path, out, rows = small_archive
    job(manifest(rows, path), out, SMALL)
    before = {name: (out / name).read_bytes() for name in ("segments.parquet", "bands.parquet", "runs.parquet")}
    forbid_solves(monkeypatch)
    import roadtex.archive.combined as combine
    written: list[str] = []
    real_write = combine.write_atomically
    monkeypatch.setattr(combine, "write_atomically", lambda path, fn: written.append(path.name) or real_write(path, fn))
    summary = job(path, out, SMALL)
    assert (summary.skipped, summary.processed) == (2, 0)
    assert written == []   # the combined tables kept (their checksums verified), not written again
    assert {name: (out / name).read_bytes() for name in before} == before
    assert json.loads((out / "parameters.json").read_text())["plan"]["reused_pilots"]


def test_a_run_added_to_a_known_group_reuses_its_pilot(small_archive, monkeypatch: pytest.MonkeyPatch) -> None:
    path, out, rows = small_archive
    # a group of more runs than its pilot reads (it speaks for runs it never tried, and says so)
    rows = rows + [(f"r{i}", roadtex.write_profile(roadtex.synthetic_pavement("dense_asphalt", 0.6, 0.5e-3, seed=i),
                                                   path.parent / f"r{i}.parquet")) for i in (2, 3)]
    job(manifest(rows, path), out, SMALL)
    monkeypatch.setattr(planning, "choose_setting", lambda *a, **k: pytest.fail("the pilot ran again"))
    added = roadtex.write_profile(roadtex.synthetic_pavement("dense_asphalt", 0.6, 0.5e-3, seed=9),
                                  path.parent / "added.parquet")
    summary = job(manifest([*rows, ("added", added)], path), out, SMALL)
    assert (summary.skipped, summary.processed) == (4, 1)


def test_a_group_its_pilot_read_whole_is_piloted_again_when_it_grows(small_archive) -> None:
    """Its statements were of its runs' own rows, not extrapolated to runs it never tried (0.5.15)."""
    path, out, rows = small_archive
    job(manifest(rows, path), out, SMALL)
    added = roadtex.write_profile(roadtex.synthetic_pavement("dense_asphalt", 0.6, 0.5e-3, seed=9),
                                  path.parent / "added.parquet")
    calls = []
    real = planning.choose_setting
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(planning, "choose_setting", lambda *a, **k: calls.append(k["sampled"]) or real(*a, **k))
        job(manifest([*rows, ("added", added)], path), out, SMALL)
    assert calls == [False]   # three runs, all read: made again, and a whole group again


@pytest.mark.parametrize("change", ["options", "pilot input", "damaged record"])
def test_what_changes_a_pilot_s_answer_makes_it_again(small_archive, change: str) -> None:
    path, out, rows = small_archive
    job(manifest(rows, path), out, SMALL)
    options = SMALL
    if change == "options":
        options = dataclasses.replace(SMALL, mean_pressure=2.5e5)
    elif change == "pilot input":
        roadtex.write_profile(roadtex.synthetic_pavement("porous_asphalt", 0.6, 0.5e-3, seed=0), rows[0][1])
    else:
        record = next((out / "plan").glob("*.json"))
        edited = json.loads(record.read_text())
        edited["record"]["pilots"][0]["worst_error_db"] = 0.0   # a smaller error than measured: never trusted
        record.write_text(json.dumps(edited))
    calls = []
    real = planning.choose_setting
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(planning, "choose_setting", lambda *a, **k: calls.append(1) or real(*a, **k))
        job(path, out, options)
    assert calls, "the kept pilot was trusted although " + change + " changed"


def test_a_run_of_a_sampling_no_pilot_read_says_where_its_errors_come_from(tmp_path: Path) -> None:
    """Of four runs of one group the pilot reads three (a0, a2, a3), all at 0.5 mm; a1, at 1 mm, is
    solved on the finest model grid of any group and carries the largest estimate, and says so."""
    rows = [(f"a{i}", roadtex.write_profile(roadtex.synthetic_pavement("dense_asphalt", 0.6, dx, seed=i),
                                            tmp_path / f"a{i}.parquet"))
            for i, dx in enumerate((0.5e-3, 1e-3, 0.5e-3, 0.5e-3))]
    job(manifest(rows, tmp_path / "m.csv"), tmp_path / "out", SMALL)
    plan = json.loads((tmp_path / "out" / "parameters.json").read_text())["plan"]
    assert [sorted(runs) for runs in plan["groups"].values()] == [["a0", "a2", "a3"]]
    pilot = next(iter(plan["group_errors"].values()))
    runs = {r["run_id"]: r for r in pl.read_parquet(tmp_path / "out" / "runs.parquet").iter_rows(named=True)}
    assert runs["a1"]["error_source"].startswith("no pilot of any device / any pavement at 1 mm")
    assert runs["a1"]["dx_used"] == 1e-3 and runs["a1"]["model_dx"] <= pilot["model_dx"] * (1 + 1e-9)
    assert runs["a1"]["worst_level_error_db"] == pilot["worst_error_db"]
    assert runs["a0"]["error_source"] == f"the pilot of its group ({next(iter(plan['group_errors']))})"


def test_a_combined_table_damaged_since_is_written_again_on_a_rerun(small_archive) -> None:
    path, out, rows = small_archive
    job(manifest(rows, path), out, SMALL)
    good = (out / "bands.parquet").read_bytes()
    (out / "bands.parquet").write_bytes(good[: len(good) // 2])
    job(path, out, SMALL)
    assert (out / "bands.parquet").read_bytes() == good


def test_the_report_s_spectra_label_every_run_s_bands(mixed) -> None:
    """Runs of different samplings report different bands: the shared band axis labels them all
    (it showed only the last panel's, leaving the 0.0375 mm run's shortest bands unlabelled)."""
    from roadtex.report.data import load_results, pyplot
    from roadtex.report.spectra_figures import fig_texture_spectra

    _, out = mixed
    results = load_results(out)
    figure = fig_texture_spectra(pyplot(), results)
    labels = {t.get_text() for t in figure.axes[len(figure.axes) // 2].get_xticklabels()}
    assert set(results.bands["label"].unique().to_list()) <= labels
