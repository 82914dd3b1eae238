"""Bands and segments without texture, and the kept pressures' load (issue: an adversarial hunt, 0.5.15).

A stretch of readings on a straight line (a reference plate flush with the road, a sensor holding its
last reading) has no texture: once its line is removed only rounding is left. Its "levels" came out
near -300 dB, reported as measured, and in a pilot's sample they were taken for a numerical error of
tens of dB, which sent every run of the group to the finest grid. Kept pressures (``keep_profiles``)
were the model grid's values at the readings, which sit on the road's tops: above the load.
"""

import warnings

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex.archive import ProcessingOptions, process
from roadtex.models.grid import reading_means
from roadtex.profiles.coverage import FLAT_SHARE, flat_segments, height_scale

OPTIONS = ProcessingOptions(youngs_moduli=(2e6, 1e7))


def test_a_constant_signal_has_no_band_power_at_all() -> None:
    """Its bands hold rounding only: -inf dB, as a band without power (periodic and measured alike)."""
    for periodic in (True, False):
        table = roadtex.third_octave_levels(np.full(1000, 3e-3), 0.5e-3, periodic=periodic)
        levels = table.filter(pl.col("lines") > 0)["level_db"].to_numpy()
        assert levels.size > 10 and np.all(np.isneginf(levels)), (periodic, levels[np.isfinite(levels)])
    # a uniform pressure (Pa, re 1 Pa) alike
    uniform = roadtex.band_levels(np.full((2, 4000), 2e5), 0.125e-3, periodic=True, reference=1.0)
    assert np.all(np.isneginf(uniform.levels[:, uniform.bands["lines"].to_numpy() > 0]))


def test_a_faint_band_far_above_rounding_keeps_its_level() -> None:
    """The floor is rounding's, 240 dB below the signal: a sine 180 dB below a 10 mm offset and a
    strong sine keeps its exact level, 20 lg(A / sqrt(2) / 1 um) dB."""
    n, dx = 4000, 0.25e-3
    x = np.arange(n) * dx
    faint = 1e-11   # m: 180 dB below the 10 mm offset
    heights = 1e-2 + 1e-3 * np.sin(2 * np.pi * x / (n * dx / 50)) + faint * np.sin(2 * np.pi * x / (n * dx / 500))
    table = roadtex.third_octave_levels(heights, dx, periodic=True)
    band = table.filter((pl.col("lower_wavelength") < n * dx / 500) & (pl.col("upper_wavelength") > n * dx / 500))
    assert band.height == 1
    assert band["level_db"].item() == pytest.approx(20 * np.log10(faint / np.sqrt(2) / 1e-6), abs=1e-4)
    # the bands between hold no power: -inf
    assert np.isneginf(table.filter(pl.col("label") == "8")["level_db"].item())


def test_flat_segments_are_told_from_faint_texture() -> None:
    rng = np.random.default_rng(0)
    heights = np.vstack([np.full(500, 0.0) + 1e-20 * rng.standard_normal(500),   # rounding of a plate at 3 mm
                         1e-7 * rng.standard_normal(500),                          # a 0.1 um noise floor: texture
                         np.zeros(500)])
    assert flat_segments(heights, 3e-3).tolist() == [True, False, True]
    assert height_scale(np.array([np.nan, -4e-3, 2e-3])) == 4e-3
    assert FLAT_SHARE * 1e-2 < 1e-9   # far below any profilometer's resolution on a 10 mm texture


def write_archive(root, flat: bool) -> "pl.DataFrame":
    rows = []
    for i in range(3):
        profile = roadtex.synthetic_pavement("dense_asphalt", length=2.0, dx=0.5e-3, seed=200 + i)
        heights = profile.heights.copy()
        if flat and i == 0:
            heights[1000:2000] = heights[1000]   # exactly its second 0.5 m segment: a plate, a held reading
        if flat and i == 1:
            heights[2000:3000] = np.linspace(heights[2000], heights[2000] + 2e-3, 1000)   # a straight ramp
        path = root / f"run{i}.csv"
        roadtex.write_profile(roadtex.Profile(heights, profile.positions, profile.dx, profile.metadata,
                                              profile.history), path)
        rows.append({"path": str(path), "run_id": f"run{i}", "pavement": "dense_asphalt", "device": "synth"})
    return pl.DataFrame(rows)


def run(tmp_path, flat: bool) -> dict[str, pl.DataFrame]:
    root = tmp_path / ("flat" if flat else "clean")
    root.mkdir()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        process(write_archive(root, flat), root / "out", OPTIONS, quiet=True)
    return {name: pl.read_parquet(root / "out" / f"{name}.parquet") for name in ("runs", "bands", "segments")}


def test_a_flat_stretch_has_no_level_and_leaves_its_group_s_plan_alone(tmp_path) -> None:
    flat, clean = run(tmp_path, True), run(tmp_path, False)
    bands = flat["bands"]
    # the flat and the ramp segments: no level, and why
    for run_id, segment in (("run0", 1), ("run1", 2)):
        rows = bands.filter((pl.col("run_id") == run_id) & (pl.col("segment") == segment))
        assert rows.height > 0 and not rows["reported"].any()
        assert rows.select(pl.min_horizontal(pl.col("texture_level", "enveloped_level", "pressure_level")
                                             .null_count())).item() == rows.height
        assert rows["reason"].str.contains("straight line").all()
        seg = flat["segments"].filter((pl.col("run_id") == run_id) & (pl.col("segment") == segment))
        assert seg["no_level_reason"].str.contains("straight line").all() and seg["contact_fraction"].null_count() == seg.height
    # no reported level is rounding noise
    reported = bands.filter(pl.col("reported"))
    assert reported.select(pl.min_horizontal(pl.col("texture_level", "enveloped_level", "pressure_level").min())).item() > -100
    # the pilot is not misled: the same grid and a statement of the same size as without the stretches
    a = flat["runs"].sort("run_id").select("refine", "tol_used", "worst_level_error_db", "within_budget")
    b = clean["runs"].sort("run_id").select("refine", "tol_used", "worst_level_error_db", "within_budget")
    assert a["refine"].to_list() == b["refine"].to_list() and a["tol_used"].to_list() == b["tol_used"].to_list()
    assert a["within_budget"].all()
    assert np.allclose(a["worst_level_error_db"].to_numpy(), b["worst_level_error_db"].to_numpy(), rtol=0.25)
    # the untouched run's own statements alike
    untouched = [t["bands"].filter((pl.col("run_id") == "run2") & pl.col("reported"))["level_error_db"].max()
                 for t in (flat, clean)]
    assert untouched[0] == pytest.approx(untouched[1], rel=0.25)


@pytest.mark.parametrize("k", [1, 2, 3, 4, 5, 8])
def test_reading_means_are_each_reading_s_cell_and_keep_the_load(k) -> None:
    rng = np.random.default_rng(k)
    fine = rng.random((3, 40 * k))
    means = reading_means(fine, k)
    assert means.shape == (3, 40)
    # the load: cells tile the period
    assert np.allclose(means.mean(axis=1), fine.mean(axis=1), rtol=1e-14)
    # each cell, by its own sum: the k points nearest reading i (edge points halved for even k)
    for i in (0, 7, 39):
        offsets = np.arange(-(k // 2), k // 2 + 1)
        weights = np.where((k % 2 == 0) & (np.abs(offsets) == k // 2), 0.5, 1.0)
        expected = (fine[:, (i * k + offsets) % (40 * k)] * weights).sum(axis=1) / weights.sum()
        assert np.allclose(means[:, i], expected, rtol=1e-14)


def test_kept_pressures_carry_the_load(tmp_path) -> None:
    """A 1 mm profile on a model grid: the kept pressure of each segment and modulus averages P."""
    profile = roadtex.synthetic_pavement("dense_asphalt", length=1.5, dx=1e-3, seed=3)
    path = tmp_path / "run0.csv"
    roadtex.write_profile(profile, path)
    options = ProcessingOptions(youngs_moduli=(1e6, 5e6), keep_profiles=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        process(pl.DataFrame({"path": [str(path)], "run_id": ["run0"], "pavement": ["dense_asphalt"]}),
                tmp_path / "out", options, quiet=True)
    runs = pl.read_parquet(tmp_path / "out" / "runs.parquet")
    assert runs["refine"].item() > 1   # the case: a model grid finer than the readings
    kept = roadtex.read_profiles(tmp_path / "out", run_id="run0")
    assert runs["segments"].item() == 3 and runs["points"].item() == 1500   # three 0.5 m segments, no overlap
    for (modulus,), rows in kept.group_by("youngs_modulus"):
        pressure = rows.sort("position")["pressure"].to_numpy()
        assert pressure.size == 1500 and pressure.min() >= 0
        per_segment = pressure.reshape(3, 500).mean(axis=1)
        assert np.allclose(per_segment, options.mean_pressure, rtol=1e-9), (modulus, per_segment)


def test_a_flat_surface_tile_has_no_level_and_the_example_map_carries_the_load(tmp_path) -> None:
    """The same on surfaces: a tile written as a plate has no level in either model, the others
    theirs; on a model grid twice finer each way the report's pressure map (each reading's cell
    mean) still averages P."""
    from roadtex.surfaces import synthetic_surface
    heights = synthetic_surface("dense_asphalt", 0.8, 0.03, 1e-3, seed=4).heights.copy()
    heights[:, 200:400] = 2e-3   # the second 0.2 m tile: a plate
    np.save(tmp_path / "s.npy", heights)
    manifest = pl.DataFrame({"path": [str(tmp_path / "s.npy")], "format": ["surface"], "dx": [1e-3], "dy": [1e-3],
                             "pavement": ["test"]})
    options = ProcessingOptions(segment_length=0.2, youngs_moduli=(2e6, 5e6), refine=2, tol=1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        process(manifest, tmp_path / "out", options, quiet=True)
    bands = pl.read_parquet(tmp_path / "out" / "bands.parquet")
    plate = bands.filter(pl.col("segment") == 1)
    assert set(plate["model"]) == {"line", "areal"} and not plate["reported"].any()
    assert plate["texture_level"].null_count() == plate.height and plate["reason"].str.contains("straight line").all()
    others = bands.filter((pl.col("segment") != 1) & pl.col("reported"))
    assert others.height > 0 and others["texture_level"].min() > -100 and others["pressure_level"].min() > -100
    example = pl.read_parquet(tmp_path / "out" / "surface_examples.parquet")
    assert example["segment"].unique().to_list() == [2]   # the middle tile: textured
    pressure = example["pressure"].to_numpy()
    assert pressure.std() > 0.5 * options.mean_pressure   # a contact map, not a uniform load
    assert pressure.mean() == pytest.approx(options.mean_pressure, rel=1e-9)
