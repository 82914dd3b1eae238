"""A new user's third walk (issue 30): what still tripped a user, each fixed and checked here."""

from __future__ import annotations

from pathlib import Path

import numpy as np
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


#: The job with a Ctrl-C (a real SIGINT to the process) as its third run's compute starts: one run
#: or more done, two in flight, three never started. Deterministic: a hook at a point of the job,
#: not a sleep per run racing the parent's signal.
INTERRUPTED_JOB = """
import os, signal, sys, threading
import roadtex.archive.worker as worker
from roadtex.cli import main
compute = worker.compute_run
lock, count = threading.Lock(), [0]
def interrupting(*args, **kwargs):
    with lock:
        count[0] += 1
        third = count[0] == 3
    if third:
        os.kill(os.getpid(), signal.SIGINT)
    return compute(*args, **kwargs)
worker.compute_run = interrupting
sys.exit(main(sys.argv[1:]))
"""


def test_ctrl_c_during_process_says_one_line_exits_130_and_leaves_no_temporaries(tmp_path: Path) -> None:
    import subprocess
    import sys

    files = survey(tmp_path / "survey", runs=6)
    pl.DataFrame({"path": [str(p) for p in files]}).write_csv(tmp_path / "manifest.csv")
    out = tmp_path / "results"
    argv = [sys.executable, "-c", INTERRUPTED_JOB, "process", str(tmp_path / "manifest.csv"), "--out", str(out), "--quiet",
            "--error-budget", "off", "--dx", str(DX), "--segment-length", "0.128", "--threads", "1"]
    job = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    stdout, stderr = job.communicate(timeout=300)
    assert job.returncode == 130, stderr
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr, stderr
    last = stderr.strip().splitlines()[-1]
    assert last.startswith("roadtex process: interrupted after ") and last.endswith(
        "of 6 runs; run the same command again to resume"), last
    done = int(last.split("interrupted after ")[1].split()[0])
    assert 1 <= done <= 4   # the runs before the third, and the two in flight at most
    assert not [p for p in out.rglob("*") if p.name.endswith(".tmp")]
    # the same command again resumes: the runs done are not computed again
    again = subprocess.run(argv[:1] + ["-m", "roadtex.cli"] + argv[3:], capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    resumed = int(again.stdout.split(" already done")[0].rsplit(" ", 1)[1])
    assert done <= resumed < 6, again.stdout   # the runs in flight at Ctrl-C finished and count too


def test_ctrl_c_while_writing_a_table_leaves_no_temporary(tmp_path: Path) -> None:
    import pytest

    from roadtex.archive.store import write_atomically

    def interrupted(path: Path) -> None:
        path.write_text("half a table")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_atomically(tmp_path / "runs.parquet", interrupted)
    assert list(tmp_path.iterdir()) == []


def test_process_prints_failure_reasons_grouped_by_cause(tmp_path: Path, capsys) -> None:
    folder = tmp_path / "survey"
    good = survey(folder, runs=1)
    short = [write_profile(synthetic_pavement("dense_asphalt", length, DX, seed=7), folder / f"short{i}.csv")
             for i, length in enumerate((0.11, 0.12))]
    (folder / "broken.csv").write_text("distance;height\nnot;numbers\n")
    pl.DataFrame({"path": [str(p) for p in (*good, *short, folder / "broken.csv")]}).write_csv(tmp_path / "m.csv")
    code = main(["process", str(tmp_path / "m.csv"), "--out", str(tmp_path / "out"), "--quiet", "--error-budget",
                 "off", "--dx", str(DX), "--segment-length", "0.128", "--threads", "1"])
    assert code == 1
    err = capsys.readouterr().err
    assert "3 run(s) failed, by cause" in err
    lines = [line.strip() for line in err.splitlines() if line.startswith("  ") and " run(s), " in line]
    assert len(lines) == 2, err
    assert lines[0].startswith("2 run(s), segment (") and "e.g. short0.csv: " in lines[0], lines
    assert lines[1].startswith("1 run(s), read (") and "e.g. broken.csv: " in lines[1], lines


def test_tables_and_report_say_why_mpd_baselines_were_rejected(tmp_path: Path) -> None:
    import numpy as np

    from roadtex.profiles import Profile
    from roadtex.report import build_report

    base = synthetic_pavement("dense_asphalt", 0.3, DX, seed=3)
    heights = base.heights.copy()
    x = np.arange(heights.size) * DX
    spiky = np.flatnonzero((x >= 0.11) & (x < 0.19))[::8]       # baseline 2: about 25 % of its samples flagged
    heights[spiky] += 5e-3
    heights[(x >= 0.21) & (x < 0.24)] = np.nan                   # baseline 3: 30 % of its readings missing
    path = write_profile(Profile.from_heights(heights, DX), tmp_path / "station.parquet")
    out = tmp_path / "out"
    process(pl.DataFrame({"path": [str(path)]}), out, OPTIONS, quiet=True, threads=1)
    runs = pl.read_parquet(out / "runs.parquet")
    assert runs["mpd_baselines"][0] == 3 and runs["mpd_valid_baselines"][0] == 1 and not runs["mpd_valid"][0]
    assert (runs["mpd_spike_rejected"][0], runs["mpd_dropout_rejected"][0]) == (1, 1)
    note = runs["mpd_rejections"][0]
    assert note.startswith("2 of 3 baselines rejected: 1 by the spike test (") and "more than 5 %" in note, note
    assert "1 by drop-outs (30 % of the readings missing, more than 10 %)" in note, note
    html = build_report(out).html.read_text(encoding="utf-8")
    assert "MPD baselines rejected" in html and "1 by the spike test" in html


def test_cli_refuses_abbreviations_and_suggests_on_typos(tmp_path: Path, capsys) -> None:
    import pytest

    from roadtex import __version__

    for typo, hint in ((["--pres", "0.3"], None), (["--moduil", "2"], "--moduil: did you mean --moduli?")):
        with pytest.raises(SystemExit) as stop:
            main(["process", "m.csv", "--out", str(tmp_path / "out"), *typo])
        assert stop.value.code == 2
        err = capsys.readouterr().err
        assert err.startswith("usage: roadtex process "), err    # the sub-command's usage, not the top level's
        assert f"unrecognized arguments: {typo[0]}" in err, err
        if hint:
            assert hint in err, err
    assert not (tmp_path / "out").exists()
    with pytest.raises(SystemExit) as stop:
        main(["-V"])
    assert stop.value.code == 0 and capsys.readouterr().out.strip() == f"roadtex {__version__}"


def test_python_api_is_as_strict_as_the_cli() -> None:
    import warnings

    import numpy as np
    import pytest

    import roadtex
    from roadtex.errors import ImplausibleParameterWarning, InvalidInputError
    from roadtex.surfaces import Surface

    # MPa given to the SI API: one refusal, naming every value, and the flag that allows it
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(InvalidInputError) as refused:
            ProcessingOptions(youngs_moduli=[1, 2, 5, 10])
    message = str(refused.value)
    assert message.count("is outside the plausible range") == 4 and "allow_implausible=True" in message
    assert not [w for w in caught if issubclass(w.category, ImplausibleParameterWarning)]
    allowed = ProcessingOptions(youngs_moduli=[1, 2, 5, 10], allow_implausible=True)
    assert allowed.youngs_moduli == (1.0, 2.0, 5.0, 10.0)
    # the flag changes nothing computed: a job's runs stay current whichever way it is set
    assert ProcessingOptions(allow_implausible=True).fingerprint() == ProcessingOptions().fingerprint()
    # a Profile where heights are taken: taken, with its own dx (issue 38); another dx is refused
    profile = synthetic_pavement("dense_asphalt", 0.1, DX, seed=1)
    given = roadtex.contact(profile, youngs_modulus=2e6, mean_pressure=2e5)
    assert np.array_equal(given.pressure, roadtex.contact(profile.heights, DX, 2e6, 2e5).pressure)
    with pytest.raises(InvalidInputError, match="leave dx out"):
        roadtex.contact(profile, 2 * DX, 2e6, 2e5)
    # a surface resampled finer than its data: refused clearly, not a grid of NaN
    surface = Surface(np.random.default_rng(1).normal(0, 1e-4, (8, 64)), 1e-3, 2e-3)
    with pytest.raises(InvalidInputError, match="dx 0.0001 m is finer than the surface's own spacing 0.001 m"):
        surface.resample(1e-4, 2e-3)
    assert surface.resample(2e-3, 4e-3).heights.shape == (4, 32)


def test_manifest_paths_are_relative_to_the_manifests_folder(tmp_path: Path, capsys) -> None:
    import shutil

    project = tmp_path / "project"
    files = survey(project / "survey")
    (project / "jobs").mkdir()
    assert main(["manifest", str(project / "survey"), "--out", str(project / "jobs" / "manifest.csv")]) == 0
    paths = pl.read_csv(project / "jobs" / "manifest.csv")["path"].to_list()
    assert paths == [f"../survey/{p.name}" for p in files]
    # the project moved (or sent to a colleague) as a whole: its manifest still finds every file
    moved = tmp_path / "elsewhere"
    shutil.move(project, moved)
    capsys.readouterr()
    code = main(["process", str(moved / "jobs" / "manifest.csv"), "--out", str(tmp_path / "out"), "--quiet",
                 "--error-budget", "off", "--dx", str(DX), "--segment-length", "0.128", "--threads", "1"])
    assert code == 0, capsys.readouterr().err
    runs = pl.read_parquet(tmp_path / "out" / "runs.parquet")
    assert sorted(Path(p).parent for p in runs["path"]) == [(moved / "survey").resolve()] * len(files)


def test_hand_written_files_two_unknown_columns_and_a_2d_npy_without_format(tmp_path: Path) -> None:
    import numpy as np

    import roadtex
    from roadtex.archive import read_manifest

    profile = synthetic_pavement("dense_asphalt", 0.3, DX, seed=5)
    x_mm, z_mm = profile.positions * 1e3, profile.heights * 1e3
    german = tmp_path / "strecke.csv"
    german.write_text("Abstand;Hoehe\n" + "".join(f"{x:.4f};{z:.5f}\n".replace(".", ",") for x, z in zip(x_mm, z_mm)))
    read = roadtex.read_profile(german, distance_unit="mm", height_unit="mm")
    np.testing.assert_allclose(read.heights, profile.heights, atol=1e-8)
    np.testing.assert_allclose(read.positions, profile.positions, atol=1e-7)
    assert any("the first ('Abstand') is read as the distance and the second ('Hoehe') as the height" in h for h in read.history)
    with __import__("pytest").raises(roadtex.ProfileFormatError, match="no height column"):
        roadtex.read_profile(german)    # units not given: not guessed
    grid = tmp_path / "scan.npy"
    np.save(grid, np.random.default_rng(2).normal(0, 3e-4, (6, 400)))
    manifest = tmp_path / "manifest.csv"
    manifest.write_text("path;dx;dy;distance_unit;height_unit\nstrecke.csv;;;mm;mm\nscan.npy;0,0005;0,001;;\n")
    table = read_manifest(manifest)
    assert table["format"].to_list() == [None, "surface"]
    summary = process(manifest, tmp_path / "out", OPTIONS, quiet=True, threads=1)
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet")
    assert (summary.failed, summary.surface_runs) == (0, 1), errors["message"].to_list()


def test_two_unknown_columns_whose_header_states_both_units_are_read_by_position(tmp_path: Path) -> None:
    """A German export as colleagues send it, "Abstand (mm);Hoehe (mm)": both units are certain (the
    header's), so the two columns are distance then height, as when the units are given; the same
    table the other way round is refused, since its first column is no row of positions."""
    import numpy as np
    import pytest

    import roadtex

    profile = synthetic_pavement("dense_asphalt", 0.3, DX, seed=6)
    rows = list(zip(profile.positions * 1e3, profile.heights * 1e3))
    german = tmp_path / "A7.csv"
    german.write_text("Site;A7 km 12\nsep=;\nAbstand (mm);Hoehe (mm)\n"
                      + "".join(f"{x:.4f};{z:.5f}\n".replace(".", ",") for x, z in rows))
    read = roadtex.read_profile(german)
    np.testing.assert_allclose(read.heights, profile.heights, atol=1e-8)
    assert read.dx == pytest.approx(DX)
    assert any("both units certain, the first ('Abstand (mm)') is read as the distance" in h for h in read.history)
    swapped = tmp_path / "A7-swapped.csv"
    swapped.write_text("Hoehe (mm);Abstand (mm)\n" + "".join(f"{z:.5f};{x:.4f}\n".replace(".", ",") for x, z in rows))
    with pytest.raises(roadtex.ProfileFormatError, match="A7-swapped.csv"):
        roadtex.read_profile(swapped)
    one_unit = tmp_path / "A7-one-unit.csv"
    one_unit.write_text("Abstand (mm);Hoehe\n" + "".join(f"{x:.4f};{z:.5f}\n".replace(".", ",") for x, z in rows))
    with pytest.raises(roadtex.ProfileFormatError, match="no height column"):
        roadtex.read_profile(one_unit)    # the height's unit not stated: nothing read by position


def test_real_data_tests_say_why_they_skip_and_how_to_run_them(tmp_path: Path) -> None:
    import os
    import subprocess
    import sys

    env = {**os.environ, "ROADTEX_CAPTIF_DIR": str(tmp_path / "no-such-folder")}
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                           str(Path(__file__).with_name("test_user_path.py")), "-k", "real_captif_files"],
                          capture_output=True, text=True, env=env, timeout=300)
    assert "1 skipped" in done.stdout, done.stdout
    line = next((line for line in done.stdout.splitlines() if "real-data test(s) skipped" in line), "")
    assert line.startswith("1 real-data test(s) skipped: no CAPTIF profiles at "), done.stdout
    assert "../shared/data/captif-slp" in line and "ROADTEX_CAPTIF_DIR" in line


def test_figures_equal_scales_finest_setting_not_a_reference_and_over_budget_bands_marked(tmp_path: Path) -> None:
    import warnings

    import matplotlib.patches
    import numpy as np

    from roadtex.report.data import load_results, pyplot
    from roadtex.report.error_budget import fig_setting_speed_vs_error
    from roadtex.report.spectra_figures import fig_pressure_spectra, fig_texture_spectra
    from roadtex.report.surface_figures import fig_line_vs_areal, fig_surface_tiles
    from roadtex.surfaces import synthetic_surface

    line = write_profile(synthetic_pavement("dense_asphalt", 0.6, DX, seed=1), tmp_path / "line.csv")
    surface = synthetic_surface("dense_asphalt", length=0.26, width=0.04, dx=DX, seed=1)
    np.save(tmp_path / "surf.npy", surface.heights)
    manifest = pl.DataFrame({"path": [str(line), str(tmp_path / "surf.npy")], "format": [None, "surface"],
                             "dx": [None, DX], "dy": [None, DX]})
    budget = 0.05    # below what 0.5 mm data can reach on their own grid (k = 1): some bands exceed it
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        process(manifest, tmp_path / "out", ProcessingOptions(youngs_moduli=(2e6, 1e7), segment_length=0.128,
                                                              error_budget_db=budget, refine=1),
                quiet=True, threads=1)
    results = load_results(tmp_path / "out")
    bands = pl.read_parquet(tmp_path / "out" / "bands.parquet")
    plt = pyplot()

    tiles = fig_surface_tiles(plt, results)
    images = [ax for ax in tiles.axes if ax.images]
    assert images and all(ax.get_aspect() == 1.0 for ax in images)   # mm along = mm across

    def hatched(ax, gid: str, labelled) -> set[str]:
        """The band labels under the patches of ``gid`` (at the nearest tick of ``labelled``)."""
        ticks = np.asarray(labelled.get_xticks())
        names = [t.get_text() for t in labelled.get_xticklabels()]
        return {names[int(np.argmin(np.abs(ticks - (p.get_x() + p.get_width() / 2))))] for p in ax.patches
                if isinstance(p, matplotlib.patches.Rectangle) and p.get_hatch() and p.get_gid() == gid}

    # the bands whose drawn mean (per modulus) may be off by more than the budget: each row raised by its
    # own stated error, in power
    rows = bands.filter((pl.col("run_id") == "line") & pl.col("level_error_db").is_not_null()
                        & pl.col("enveloped_level").is_finite())
    means = rows.group_by("label", "youngs_modulus").agg(
        (10 * ((10 ** (pl.col("enveloped_level") / 10) * 10 ** (pl.col("level_error_db") / 10)).sum()
               / (10 ** (pl.col("enveloped_level") / 10)).sum()).log10()).alias("enveloped"),
        (10 * ((10 ** (pl.col("pressure_level") / 10) * 10 ** (pl.col("level_error_db") / 10)).sum()
               / (10 ** (pl.col("pressure_level") / 10)).sum()).log10()).alias("pressure"))
    over = set(means.filter(pl.max_horizontal("enveloped", "pressure") > budget)["label"].to_list())
    assert over, "the test needs bands over the budget"
    for draw in (fig_texture_spectra, fig_pressure_spectra):
        fig = draw(plt, results)
        panel = next(ax for ax in fig.axes if ax.get_title() == "line")
        column = [ax for ax in fig.axes if ax.get_position().x0 == panel.get_position().x0]
        labelled = column[-1]   # the bottom panel of the column carries the band labels
        assert hatched(panel, "over_budget", labelled) == over
        assert "band whose stated error exceeds the budget" in [t.get_text() for t in fig.legends[0].get_texts()]
    areal = fig_line_vs_areal(plt, results)
    assert any(p.get_gid() == "over_budget" for p in areal.axes[0].patches), \
        "the surface run's bands over the budget are marked too"

    speed = fig_setting_speed_vs_error(plt, results)
    texts = [t.get_text() for ax in speed.axes for t in ax.texts]
    # the finest setting is the reference: the data's grid refined until converged (issue 34), its
    # own estimated error drawn where it lies
    assert any(t.endswith("(reference)") for t in texts)
    pilot = pl.read_parquet(tmp_path / "out" / "pilot.parquet")
    settings = pilot.select("group", "dx", "refine", "tol").unique().height
    panel = speed.axes[0]
    drawn = sum(len(line.get_xdata()) for line in panel.lines if line.get_marker() == "o")
    edge = sum(len(c.get_offsets()) for c in panel.collections if c.get_label().startswith("not every budget band"))
    assert drawn + edge == settings    # every setting the pilot evaluated is on the panel
    plt.close("all")


def test_units_are_in_the_arrow_schema_of_every_table(tmp_path: Path) -> None:
    import json

    import pytest

    from roadtex.archive.schemas import TABLES, units

    pq = pytest.importorskip("pyarrow.parquet", reason="pyarrow (a test requirement) reads the Arrow schema")
    files = survey(tmp_path / "survey", runs=1)
    process(pl.DataFrame({"path": [str(files[0])]}), tmp_path / "out", OPTIONS, quiet=True, threads=1)
    checked = 0
    for name, columns in TABLES.items():
        path = tmp_path / "out" / f"{name}.parquet"
        if not path.exists():
            continue
        schema = pq.read_table(path).schema
        found = {field.name: field.metadata[b"unit"].decode() for field in schema
                 if field.metadata and b"unit" in field.metadata}
        assert found == units(columns), name
        assert json.loads(schema.metadata[b"units"]) == units(columns), name
        assert pl.read_parquet(path).columns == list(columns)
        checked += 1
    assert checked >= 9
    runs = pq.read_table(tmp_path / "out" / "runs.parquet")
    assert runs.schema.field("mpd").metadata == {b"unit": b"m"} and runs.num_rows == 1


def test_budget_warning_at_a_coarse_given_dx_says_which_bands_have_no_error_not_inf(tmp_path: Path) -> None:
    import warnings

    from roadtex.errors import ErrorBudgetWarning

    files = survey(tmp_path / "survey", runs=2, length=1.0)
    options = ProcessingOptions(youngs_moduli=(2e6, 1e7), dx=0.01, segment_length=0.5)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        process(pl.DataFrame({"path": [str(p) for p in files]}), tmp_path / "out", options, quiet=True, threads=1)
    budget = [str(w.message) for w in caught if issubclass(w.category, ErrorBudgetWarning)]
    assert len(budget) == 1, budget
    assert "inf dB" not in budget[0] and "the given dx of 10 mm" in budget[0], budget[0]
    assert "no error can be stated for" in budget[0] and "which dx 10 mm is too coarse to report" in budget[0]


def test_corrupt_files_raise_profile_format_error_naming_them(tmp_path: Path) -> None:
    import numpy as np
    import pytest

    import roadtex
    from roadtex.errors import ProfileFormatError

    for shape, read in (((40, 50), lambda p: roadtex.read_surface(p, dx=1e-3, dy=1e-3)),
                        ((2000,), lambda p: roadtex.read_profile(p, dx=1e-3))):
        good = tmp_path / "good.npy"
        np.save(good, np.random.default_rng(0).normal(0, 1e-4, shape))
        data = good.read_bytes()
        corrupt = tmp_path / f"corrupt{len(shape)}.npy"
        # the header intact, the data overwritten: heights of 1e300 m, as random bytes give
        corrupt.write_bytes(data[:128] + np.full(shape, 1e300).tobytes())
        with pytest.raises(ProfileFormatError, match=rf"^{corrupt.name}: a height .* is beyond 1e\+09 m"):
            read(corrupt)


def test_plausibility_judgement_skips_the_medians_it_does_not_need() -> None:
    import numpy as np

    import roadtex.profiles.plausibility as plausibility

    # the count-based median test is the median test, ties and drop-outs included
    rng = np.random.default_rng(4)
    for _ in range(200):
        values = rng.integers(0, 6, size=(3, int(rng.integers(1, 12)))).astype(float)
        values[rng.random(values.shape) < 0.2] = np.nan
        values[:, 0] = rng.integers(0, 6, size=3)   # at least one valid value per row
        for threshold in (0.5, 2.0, 2.5, 3.0):
            np.testing.assert_array_equal(plausibility.median_above(values, threshold),
                                          np.nanmedian(values, axis=1) > threshold)
    # texture without drop-out codes: the gross-outlier medians are not computed; with one, they are
    calls = []
    real = plausibility.gross_outliers
    plausibility.gross_outliers = lambda rows: calls.append(rows.size) or real(rows)
    try:
        texture = synthetic_pavement("dense_asphalt", 10.0, 5e-5, seed=2).heights
        assert plausibility.implausible_texture(texture, 5e-5, "t.csv") is None and calls == []
        coded = texture.copy()
        coded[1000] = -0.85
        assert plausibility.implausible_texture(coded, 5e-5, "t.csv") is None and calls == [texture.size]
        assert "were the heights given in millimetres" in plausibility.implausible_texture(texture * 1e3, 5e-5, "t.csv")
    finally:
        plausibility.gross_outliers = real


def test_manifest_and_process_agree_on_implausible_surfaces(tmp_path: Path) -> None:
    import warnings

    import numpy as np

    from roadtex.errors import ImplausibleTextureWarning
    from roadtex.surfaces import synthetic_surface

    folder = tmp_path / "survey"
    folder.mkdir()
    surface = synthetic_surface("dense_asphalt", length=0.26, width=0.04, dx=DX, seed=3)
    ny, nx = surface.heights.shape
    x, y = np.meshgrid(np.arange(nx) * DX, np.arange(ny) * DX)
    for name, factor in (("in_mm", 1e3), ("in_m", 1.0)):   # the first in millimetres, headed as metres
        pl.DataFrame({"x (m)": x.ravel(), "y (m)": y.ravel(), "z (m)": surface.heights.ravel() * factor}
                     ).write_csv(folder / f"{name}.csv")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = build_manifest(folder)
    said = [str(w.message) for w in caught if issubclass(w.category, ImplausibleTextureWarning)]
    assert table["format"].to_list() == ["surface", "surface"]
    assert len(said) == 1 and "in_mm.csv" in said[0], said
    assert "roadtex process refuses it" in said[0] and "Computing as given" not in said[0], said[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        process(table, tmp_path / "out", OPTIONS, quiet=True, threads=1)
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet")
    assert errors["run_id"].to_list() == ["in_mm"]          # refused, as the manifest said; the other processed
    assert "implausible" in errors["message"][0]


def test_demo_refuses_implausible_moduli_as_process_does(tmp_path: Path, capsys) -> None:
    assert main(["demo", "--out", str(tmp_path / "demo"), "--moduli", "0.001", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("roadtex demo: error: --moduli 0.001 MPa is outside the plausible range"), err
    assert "Traceback" not in err and not (tmp_path / "demo").exists()


def test_a_sidecar_is_not_named_as_a_file_left_out(tmp_path: Path) -> None:
    # walk on agency-style data: a 2-D .npy surface with its x.npy.json sidecar (dx, dy) was listed
    # as a file left out ("suffix '.json', not one of the profile files'"), though it is read with x.npy
    from roadtex.archive.manifest import unlisted_files

    np.save(tmp_path / "surface.npy", np.zeros((8, 64)))
    (tmp_path / "surface.npy.json").write_text('{"dx": 0.001, "dy": 0.001}')
    (tmp_path / "notes.json").write_text("{}")
    notes = unlisted_files(tmp_path)
    assert not any(n.startswith("surface.npy.json") for n in notes)
    assert any(n.startswith("notes.json") for n in notes)   # a .json of no profile is still named


def test_ctrl_c_counts_the_runs_in_flight_that_finish(tmp_path: Path, monkeypatch) -> None:
    # found on a fresh clone: Ctrl-C while a finished run was not yet collected said "interrupted
    # after 0 of 6 runs" though its results were complete on disk (the runs in flight finish)
    import pytest

    import roadtex.archive.job as job
    from roadtex.errors import JobInterrupted

    files = survey(tmp_path / "survey", runs=3)
    pl.DataFrame({"path": [str(p) for p in files]}).write_csv(tmp_path / "manifest.csv")

    def interrupted_engine(work, runs, sizes, options, out, threads, flags):
        yield work(runs[0], options, out, threads=threads, **flags), sizes[0]
        work(runs[1], options, out, threads=threads, **flags)   # in flight: finishes, never collected
        raise KeyboardInterrupt

    monkeypatch.setattr(job, "process_local", interrupted_engine)
    options = ProcessingOptions(error_budget_db=None, dx=DX, segment_length=0.128)
    with pytest.raises(JobInterrupted) as caught:
        process(tmp_path / "manifest.csv", tmp_path / "out", options, quiet=True)
    assert (caught.value.done, caught.value.runs) == (2, 3)
