"""The bulk job on 3D surface runs: areal and line rows, the plane-strain check, failures, units."""

import json

import numpy as np
import polars as pl
import pytest

from roadtex.archive import ProcessingOptions, process
from roadtex.profiles import synthetic_pavement
from roadtex.surfaces import synthetic_surface

OPTIONS = ProcessingOptions(segment_length=0.2, youngs_moduli=(2e6, 5e6), tol=1e-8)


def run_job(tmp_path, heights, dx=1e-3, dy=1e-3, name="s", options=OPTIONS):
    path = tmp_path / f"{name}.npy"
    np.save(path, heights)
    manifest = pl.DataFrame({"path": [str(path)], "format": ["surface"], "dx": [dx], "dy": [dy],
                             "pavement": ["test"]})
    summary = process(manifest, tmp_path / "out", options, quiet=True)
    return summary, {name: pl.read_parquet(tmp_path / "out" / f"{name}.parquet")
                     for name in ("segments", "bands", "runs", "errors")}


def test_surface_run_gives_line_and_areal_rows(tmp_path):
    surface = synthetic_surface("dense_asphalt", 0.4, 0.05, 1e-3, seed=3)
    summary, tables = run_job(tmp_path, surface.heights)
    assert summary.failed == 0 and tables["errors"].height == 0
    seg, bands = tables["segments"], tables["bands"]
    assert set(seg["model"]) == {"line", "areal"}
    assert set(bands["model"]) == {"line", "areal"}
    # two tiles along 0.4 m, five lines, two moduli
    assert seg.filter(pl.col("model") == "areal").height == 2 * 2
    assert seg.filter(pl.col("model") == "line").height == 2 * 5 * 2
    assert seg.filter(pl.col("model") == "areal")["line"].null_count() == 4
    assert seg["converged"].all()
    # stiffer rubber touches less of the road, in both models
    for model in ("line", "areal"):
        by_e = seg.filter(pl.col("model") == model).group_by("youngs_modulus").agg(pl.col("contact_fraction").mean()).sort("youngs_modulus")
        assert by_e["contact_fraction"][0] > by_e["contact_fraction"][1]
    # both models' rows carry the run's own (areal pilot's) error estimate in every reported band
    # and none where no level is reported
    for model in ("line", "areal"):
        rows = bands.filter(pl.col("model") == model)
        assert rows.filter(pl.col("reported"))["level_error_db"].null_count() == 0
        assert rows.filter(~pl.col("reported"))["level_error_db"].null_count() == rows.filter(~pl.col("reported")).height
    assert tables["runs"]["segments"][0] == 2


def test_extruded_profile_areal_equals_line(tmp_path):
    """A line profile extruded across the road: the areal model is in plane strain, so its rows
    equal the line model's to solver tolerance."""
    line = synthetic_pavement("dense_asphalt", 0.4, 1e-3, seed=5).heights
    heights = np.tile(line[:400], (8, 1))
    _, tables = run_job(tmp_path, heights)
    bands = tables["bands"].filter(pl.col("reported"))
    keys = ["segment", "line", "youngs_modulus", "band"]
    joined = bands.filter(pl.col("model") == "line").join(bands.filter(pl.col("model") == "areal"), on=keys, suffix="_areal")
    assert joined.height == bands.height // 2 > 0
    diff = (joined["enveloped_level"] - joined["enveloped_level_areal"]).abs()
    assert diff.max() < 1e-6      # dB; tol 1e-8 on both solvers
    pdiff = (joined["pressure_level"] - joined["pressure_level_areal"]).abs()
    assert pdiff.max() < 1e-5
    seg = tables["segments"]
    line_cf = seg.filter(pl.col("model") == "line").group_by(["segment", "youngs_modulus"]).agg(pl.col("contact_fraction").mean())
    areal_cf = seg.filter(pl.col("model") == "areal").select("segment", "youngs_modulus", "contact_fraction")
    both = line_cf.join(areal_cf, on=["segment", "youngs_modulus"], suffix="_areal")
    assert np.allclose(both["contact_fraction"], both["contact_fraction_areal"], atol=1e-12)


def test_surface_failure_recorded(tmp_path):
    bad = tmp_path / "bad.npy"
    np.save(bad, np.zeros(5))      # 1-D: not a surface
    short = tmp_path / "short.npy"
    np.save(short, synthetic_surface("dense_asphalt", 0.05, 0.02, 1e-3, seed=1).heights)  # shorter than a tile
    manifest = pl.DataFrame({"path": [str(bad), str(short)], "format": ["surface", "surface"],
                             "dx": [1e-3, 1e-3], "dy": [1e-3, 1e-3]})
    summary = process(manifest, tmp_path / "out", OPTIONS, quiet=True)
    assert summary.failed == 2
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet").sort("run_id")
    assert errors["stage"].to_list() == ["read", "segment"]


def test_surface_tables_keep_units(tmp_path):
    surface = synthetic_surface("porous_asphalt", 0.2, 0.03, 1e-3, seed=2)
    run_job(tmp_path, surface.heights)
    for name in ("segments", "bands"):
        units = json.loads(pl.read_parquet_metadata(tmp_path / "out" / f"{name}.parquet")["units"])
        assert units["youngs_modulus"] == "Pa" and units["line"] == "count"
        assert "model" not in units


def test_manifest_rejects_nonpositive_dy(tmp_path):
    from roadtex.errors import ManifestError
    path = tmp_path / "s.npy"
    np.save(path, np.zeros((3, 30)))
    with pytest.raises(ManifestError, match="dy"):
        process(pl.DataFrame({"path": [str(path)], "format": ["surface"], "dy": [-1.0]}), tmp_path / "out", OPTIONS)


def test_surface_example_is_the_middle_tile(tmp_path):
    surface = synthetic_surface("dense_asphalt", 0.6, 0.03, 1e-3, seed=4)
    # on the data's grid, where the map's pressure is the solve's own at each reading (a finer model
    # grid's map holds each reading's cell mean, which can be > 0 where the reading itself is free)
    run_job(tmp_path, surface.heights, options=ProcessingOptions(**{**OPTIONS.__dict__, "refine": 1}))
    example = pl.read_parquet(tmp_path / "out" / "surface_examples.parquet")
    assert example["segment"].unique().to_list() == [1]
    assert example["youngs_modulus"].unique().to_list() == [5e6]     # middle of (2e6, 5e6) by index 1
    assert example.height == 200 * 30
    # the rubber never goes below the road; it touches where there is pressure
    gap = (example["envelope"] - example["height"]).to_numpy()
    assert gap.min() > -1e-9
    touching = example["pressure"].to_numpy() > 0
    assert np.abs(gap[touching]).max() < 1e-6
    assert abs(example["pressure"].mean() - OPTIONS.mean_pressure) < 1e-6 * OPTIONS.mean_pressure


def test_surface_runs_solved_a_chunk_of_tiles_at_a_time_give_the_same_tables(tmp_path, monkeypatch) -> None:
    """Memory bounded as for line runs: tiles solved in chunks give the tables of one call, bit for bit."""
    import numpy as np
    import polars as pl
    from polars.testing import assert_frame_equal

    import roadtex
    from roadtex.archive import ProcessingOptions, process, surface_run
    from roadtex.surfaces import synthetic_surface

    surface = synthetic_surface("dense_asphalt", 0.5, 0.02, 0.5e-3, seed=3)
    np.save(tmp_path / "s.npy", surface.heights)
    manifest = pl.DataFrame({"path": [str(tmp_path / "s.npy")], "format": ["surface"], "dx": [0.5e-3], "dy": [0.5e-3]})
    options = ProcessingOptions(youngs_moduli=(2e6, 1e7), segment_length=0.1, error_budget_db=None, tol=1e-8)
    process(manifest, tmp_path / "whole", options, quiet=True)
    tile_points = 200 * 40
    monkeypatch.setattr(surface_run, "CHUNK_POINTS", 2 * tile_points)     # 2 tiles per call: 3 calls
    process(manifest, tmp_path / "chunked", options, quiet=True)
    for name in ("segments", "bands", "surface_examples"):
        whole = pl.read_parquet(tmp_path / "whole" / f"{name}.parquet")
        assert whole.height > 0
        assert_frame_equal(pl.read_parquet(tmp_path / "chunked" / f"{name}.parquet"), whole, check_exact=True)
    assert roadtex.errors  # the package imported whole


def test_surface_runs_on_dask_give_the_local_engines_tables_bit_for_bit(tmp_path) -> None:
    import numpy as np
    import polars as pl
    import pytest
    from polars.testing import assert_frame_equal

    from roadtex.archive import ProcessingOptions, process
    from roadtex.surfaces import synthetic_surface

    pytest.importorskip("distributed", reason="dask.distributed is a dev requirement; install roadtex[dask]")
    surface = synthetic_surface("porous_asphalt", 0.3, 0.02, 0.5e-3, seed=2)
    np.save(tmp_path / "s.npy", surface.heights)
    manifest = pl.DataFrame({"path": [str(tmp_path / "s.npy")], "format": ["surface"], "dx": [0.5e-3], "dy": [0.5e-3]})
    options = ProcessingOptions(youngs_moduli=(2e6, 1e7), segment_length=0.1, error_budget_db=None, tol=1e-8)
    process(manifest, tmp_path / "local", options, quiet=True)
    process(manifest, tmp_path / "dask", options, engine="dask", workers=1, quiet=True)
    for name in ("segments", "bands", "surface_examples", "runs"):
        assert_frame_equal(pl.read_parquet(tmp_path / "dask" / f"{name}.parquet"),
                           pl.read_parquet(tmp_path / "local" / f"{name}.parquet"), check_exact=True)


def test_an_opencrg_surface_goes_through_the_job_from_the_folder_listing(tmp_path) -> None:
    """A .crg file in a survey folder: listed by build_manifest, solved as a surface run (both models)."""
    import numpy as np
    import polars as pl
    import pytest

    from roadtex.archive import ProcessingOptions, build_manifest, process
    from roadtex.surfaces import synthetic_surface

    pycrg = pytest.importorskip("pycrg", reason="pycrg (OpenCRG) is a dev requirement; pip install pycrg")
    surface = synthetic_surface("dense_asphalt", 0.3, 0.02, 0.5e-3, seed=4)
    ny = surface.heights.shape[0]
    v = (np.arange(ny) - (ny - 1) / 2) * 0.5e-3
    folder = tmp_path / "survey"
    folder.mkdir()
    pycrg.write(folder / "lane.crg", surface.heights.T.copy(), 0.5e-3, v, 0.0, mods={}, comment="roadtex job test",
                fmt="KRBI")
    manifest = build_manifest(folder)
    options = ProcessingOptions(youngs_moduli=(2e6,), segment_length=0.1, error_budget_db=None, tol=1e-8)
    summary = process(manifest, tmp_path / "out", options, quiet=True)
    assert summary.failed_on_record == 0, pl.read_parquet(tmp_path / "out" / "errors.parquet")
    models = set(pl.read_parquet(tmp_path / "out" / "segments.parquet")["model"])
    assert models == {"line", "areal"}


def test_a_strip_too_narrow_for_the_areal_model_fails_at_read_naming_the_file(tmp_path):
    narrow = tmp_path / "narrow.npy"
    np.save(narrow, synthetic_surface("dense_asphalt", 0.4, 0.003, 1e-3, seed=2).heights[:3])   # 3 rows
    manifest = pl.DataFrame({"path": [str(narrow)], "format": ["surface"], "dx": [1e-3], "dy": [1e-3]})
    assert process(manifest, tmp_path / "out", OPTIONS, quiet=True).failed == 1
    error = pl.read_parquet(tmp_path / "out" / "errors.parquet").row(0, named=True)
    assert error["stage"] == "read" and error["message"].startswith("narrow.npy: 3 row(s) across the road")
    assert "at least 4" in error["message"]
