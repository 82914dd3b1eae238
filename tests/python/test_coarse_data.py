"""Coarse data, honestly (issue 34, item 4): a file whose distance unit is certain (OpenCRG, a unit
its header states, one given for it) is never refused for its interval alone; above 5 mm it is
processed with a CoarseSamplingWarning and only the bands its sampling resolves are reported. A
file whose unit is assumed is still refused with the "given in millimetres?" advice, unless
--allow-implausible, which now works at the read, plan and surface stages too.

The deliverable: a synthetic Belgian-block (sett) surface on a 1 cm grid, written as OpenCRG, goes
through ``roadtex manifest``, ``roadtex process`` and ``roadtex report``.

What the setts' geometry gives (``sett_surface``'s defaults: setts 150 mm along by 100 mm across,
joints 10 to 20 mm wide and 3 to 10 mm deep, tops domed 2 mm, levels 0.7 mm sd):

- MPD: a 100 mm ISO baseline holds a joint about (100 + 15) / 165 = 70 % of the time, which lowers
  its mean by about 6.5 mm x 15 mm / 100 mm = 1 mm below its peaks; the domes (2 mm crown, 1.3 mm
  on average across a sett), the neighbouring setts' levels and the roughness add 0.5 to 1 mm.
  Expected MPD 1 to 2.5 mm. The same setts sampled every 1 mm (an independent sampling of the same
  road) give MPD within 20 % of the 1 cm file's.
- Long bands: the joints recur every sett pitch (about 165 mm, in the 160 mm third octave) and
  the domes peak midway: the texture level peaks in the band holding the pitch; for wavelengths
  of 31.5 mm and more (3 samples a wavelength and more) the 1 cm file's levels are those of the
  same setts sampled every 1 mm, within 1 dB.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex.archive import ProcessingOptions, process
from roadtex.cli import main
from roadtex.errors import CoarseSamplingWarning, ImplausibleTextureWarning, InvalidInputError
from roadtex.profiles.plausibility import DISTANCE_UNIT_STATED
from roadtex.spectra import band_levels
from roadtex.surfaces import read_surface, sett_surface

DX = 0.01          # 1 cm, as OpenCRG road files are sampled
LENGTH, WIDTH = 6.2, 0.4
SEGMENT = 3.0      # 3 m tiles: bands up to 250 mm meet the 12-wavelength limit
ROWS = [0, 10, 20, 29, 39]   # the job's analysed lines of a 40-row surface (surface_run.line_rows)


def write_crg(path: Path, surface: roadtex.Surface) -> Path:
    pycrg = pytest.importorskip("pycrg", reason="pycrg (OpenCRG) is a dev requirement; pip install pycrg")
    ny = surface.heights.shape[0]
    v = (np.arange(ny) - (ny - 1) / 2) * surface.dy
    pycrg.write(path, surface.heights.T.copy(), surface.dx, v, 0.0, mods={}, comment=["Belgian block, synthetic"],
                fmt="KRBI")
    return path


def fine_reference(seed: int) -> tuple[float, dict[str, float]]:
    """MPD (m) and mean texture level per band label (dB) of the same setts sampled every 1 mm
    along the road (same rows, same 3 m stretches, each its own line removed)."""
    fine = sett_surface(LENGTH, WIDTH, 1e-3, DX, seed=seed)
    lines = fine.lines(rows=ROWS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", roadtex.RoadtexWarning)
        depth = float(np.mean([roadtex.mpd(p).mpd for p in lines]))
    n = int(round(SEGMENT / 1e-3))
    stretches = np.concatenate([p.heights[None, k * n:(k + 1) * n] for p in lines for k in range(2)])
    x = np.arange(n)
    slope, offset = np.polyfit(x, stretches.T, 1)
    stretches = stretches - (slope[:, None] * x[None, :] + offset[:, None])
    levels = band_levels(stretches, 1e-3, periodic=True)
    mean = levels.levels.mean(axis=0)
    return depth, dict(zip(levels.bands["label"].to_list(), mean.tolist()))


def test_sett_surface_has_the_setts_geometry() -> None:
    surface = sett_surface(LENGTH, WIDTH, DX, seed=1)
    assert surface.shape == (40, 620) and (surface.dx, surface.dy) == (DX, DX)
    pitch = surface.metadata["mean_pitch"]
    assert 0.150 + 0.010 <= pitch <= 0.150 * 1.05 + 0.020   # a sett (+-5 %) and a joint (10 to 20 mm)
    # the joints between courses lie 3 to 10 mm below the setts, across the whole width: about
    # 15 mm of every 165 mm along the road (9 %), 1 or 2 samples each at 1 cm
    across = np.median(surface.heights, axis=0)
    low = across < np.median(across) - 2.5e-3
    assert 0.06 < low.mean() < 0.12
    assert np.array_equal(sett_surface(LENGTH, WIDTH, DX, seed=1).heights, surface.heights)
    with pytest.raises(InvalidInputError, match="unknown option"):
        sett_surface(1.0, 0.2, DX, cobble=1.0)


def test_a_belgian_block_opencrg_surface_goes_through_manifest_process_and_report(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """The 1 cm OpenCRG sett surface, refused before as 'millimetres given as metres' whatever the
    manifest or --allow-implausible said, is listed, processed with a warning and reported; its
    MPD and long bands are those of its geometry."""
    folder = tmp_path / "survey"
    folder.mkdir()
    surface = sett_surface(LENGTH, WIDTH, DX, seed=1)
    write_crg(folder / "setts.crg", surface)
    manifest, out = tmp_path / "manifest.csv", tmp_path / "out"
    assert main(["manifest", str(folder), "--out", str(manifest)]) == 0
    said = capsys.readouterr().err
    assert "setts.crg: sampled every 10 mm" in said and "m (OpenCRG)" in said
    assert main(["process", str(manifest), "--out", str(out), "--segment-length", str(SEGMENT), "--moduli", "2", "10",
                 "--quiet"]) == 0
    said = capsys.readouterr().err
    assert "roadtex: warning: setts.crg: sampled every 10 mm" in said
    assert "Only the bands its sampling resolves are reported" in said
    assert "millimetres" not in said
    assert main(["report", str(out)]) == 0
    assert (out / "report" / "report.html").is_file()

    fine_mpd, fine_levels = fine_reference(seed=1)
    run = pl.read_parquet(out / "runs.parquet").row(0, named=True)
    assert run["file_dx"] == pytest.approx(DX) and run["mpd_valid"]
    assert 1.0e-3 <= run["mpd"] <= 2.5e-3, run["mpd"]              # the geometry's range (module docstring)
    assert abs(run["mpd"] - fine_mpd) <= 0.2 * fine_mpd, (run["mpd"], fine_mpd)

    bands = pl.read_parquet(out / "bands.parquet").filter(pl.col("model") == "line")
    per_band = (bands.group_by("band", "label", "centre_wavelength")
                .agg(pl.col("reported").all(), pl.col("reason").first(), pl.col("texture_level").mean())
                .sort("band"))
    short = per_band.filter(pl.col("centre_wavelength") < 2.5 * DX * (1 - 1e-9))
    assert short.height > 0 and not short["reported"].any()
    assert all("under 2.5 sampling intervals (25 mm)" in reason for reason in short["reason"])
    long = per_band.filter(pl.col("centre_wavelength").is_between(2.5 * DX * (1 - 1e-9), 0.21))
    assert long["label"].to_list() == ["200", "160", "125", "100", "80", "63", "50", "40", "31.5", "25"]
    assert long["reported"].all()
    # the texture level peaks in the band holding the sett pitch (the 160 mm third octave)
    pitch = surface.metadata["mean_pitch"]
    peak = long.filter(pl.col("centre_wavelength") >= 0.05).sort("texture_level").row(-1, named=True)
    assert peak["label"] == "160" and 0.141 < pitch < 0.178
    # and the 1 cm file's long bands are the 1 mm sampling's of the same setts
    for label, level in long.filter(pl.col("centre_wavelength") >= 0.03).select("label", "texture_level").iter_rows():
        assert abs(level - fine_levels[label]) < 1.0, (label, level, fine_levels[label])


def write_line_files(folder: Path) -> np.ndarray:
    """One line of the setts at 1 cm, as a CSV whose header states its units and as a .npy of
    (distance, height) pairs in metres that states none."""
    folder.mkdir()
    heights = sett_surface(LENGTH, WIDTH, DX, seed=2).heights[20]
    x = DX * np.arange(heights.size)
    rows = "".join(f"{a:.3f},{b * 1e3:.4f}\n" for a, b in zip(x, heights))
    (folder / "stated.csv").write_text("distance (m),height (mm)\n" + rows)
    np.save(folder / "bare.npy", np.column_stack([x, heights]))
    return heights


OPTIONS = ProcessingOptions(youngs_moduli=(2e6,), segment_length=SEGMENT)


def test_a_line_profile_at_1_cm_is_processed_when_its_units_are_stated_and_refused_when_not(tmp_path: Path) -> None:
    write_line_files(tmp_path / "lines")
    manifest = pl.DataFrame({"path": [str(tmp_path / "lines" / "stated.csv"), str(tmp_path / "lines" / "bare.npy")],
                             "run_id": ["stated", "bare"]})
    with pytest.warns(CoarseSamplingWarning, match=r"stated\.csv: sampled every 10 mm.*unit is m \(the file's "
                      r"header\).*Only the bands its sampling resolves are reported"):
        summary = process(manifest, tmp_path / "out", OPTIONS, quiet=True)
    assert (summary.processed, summary.failed) == (1, 1)
    error = pl.read_parquet(tmp_path / "out" / "errors.parquet").row(0, named=True)
    assert error["run_id"] == "bare" and error["stage"] == "read"
    assert "bare.npy: a sampling interval of 0.01 m is implausibly coarse" in error["message"]
    assert "were they given in millimetres?" in error["message"] and "--allow-implausible" in error["message"]
    bands = pl.read_parquet(tmp_path / "out" / "bands.parquet")
    assert set(bands["run_id"]) == {"stated"}
    assert not bands.filter(pl.col("centre_wavelength") < 0.025 * (1 - 1e-9))["reported"].any()
    assert bands.filter(pl.col("centre_wavelength").is_between(0.025, 0.2))["reported"].all()

    # the manifest stating the .npy's unit makes it certain; --allow-implausible processes it as read,
    # the plan's pilot included
    stated = manifest.with_columns(pl.Series("distance_unit", [None, "m"]))
    with pytest.warns(CoarseSamplingWarning, match=r"bare\.npy: sampled every 10 mm.*m \(given for the file\)"):
        assert process(stated, tmp_path / "given", OPTIONS, quiet=True).failed == 0
    with pytest.warns(ImplausibleTextureWarning, match=r"bare\.npy: a sampling interval of 0\.01 m.*Processed as read"):
        summary = process(manifest, tmp_path / "allowed", ProcessingOptions(
            youngs_moduli=(2e6,), segment_length=SEGMENT, allow_implausible=True), quiet=True)
    assert (summary.processed, summary.failed) == (2, 0)
    plan = json.loads((tmp_path / "allowed" / "parameters.json").read_text())["plan"]
    piloted = [run for runs in plan["groups"].values() for run in runs]
    assert plan["unread_runs"] == {} and sorted(piloted) == ["bare", "stated"]


def test_allow_implausible_processes_a_given_coarse_interval_on_the_command_line(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """--input-dx 0.01 for heights only: refused without --allow-implausible (a bare number's unit
    is not certain), processed with it; before, the flag passed the command line and the run
    still failed at the read stage."""
    heights = write_line_files(tmp_path / "lines")
    np.save(tmp_path / "lines" / "heights.npy", heights)
    manifest = tmp_path / "manifest.csv"
    pl.DataFrame({"path": [str(tmp_path / "lines" / "heights.npy")]}).write_csv(manifest)
    common = ["process", str(manifest), "--segment-length", str(SEGMENT), "--moduli", "2", "--input-dx", "0.01",
              "--quiet"]
    assert main([*common, "--out", str(tmp_path / "refused")]) == 2
    assert "--input-dx 0.01 m is coarser than any texture profile's sampling" in capsys.readouterr().err
    assert main([*common, "--out", str(tmp_path / "out"), "--allow-implausible"]) == 0
    said = capsys.readouterr().err
    assert "heights.npy: a sampling interval of 0.01 m" in said and "Processed as read" in said
    assert "heights.npy: sampled every 10 mm" in said and "Only the bands its sampling resolves" in said
    assert pl.read_parquet(tmp_path / "out" / "runs.parquet")["file_dx"].to_list() == [pytest.approx(DX)]


def test_a_surface_whose_spacing_is_a_bare_number_is_refused_unless_allowed(tmp_path: Path) -> None:
    surface = sett_surface(LENGTH, WIDTH, DX, seed=3)
    np.save(tmp_path / "setts.npy", surface.heights)
    manifest = pl.DataFrame({"path": [str(tmp_path / "setts.npy")], "format": ["surface"], "dx": [DX], "dy": [DX]})
    summary = process(manifest, tmp_path / "out", OPTIONS, quiet=True)
    assert summary.failed == 1
    error = pl.read_parquet(tmp_path / "out" / "errors.parquet").row(0, named=True)
    assert error["stage"] == "read" and "setts.npy" in error["message"]
    assert "The interval dx = 0.01 given for it" in error["message"] and "--allow-implausible" in error["message"]
    allowed = ProcessingOptions(youngs_moduli=(2e6,), segment_length=SEGMENT, allow_implausible=True)
    with pytest.warns(ImplausibleTextureWarning, match=r"setts\.npy: .*Processed as read"):
        assert process(manifest, tmp_path / "allowed", allowed, quiet=True).failed == 0


def test_readers_say_where_the_unit_comes_from_and_trust_no_stored_claim(tmp_path: Path) -> None:
    surface = sett_surface(1.0, 0.1, DX, seed=4)
    crg = write_crg(tmp_path / "setts.crg", surface)
    with pytest.warns(CoarseSamplingWarning, match=r"setts\.crg: sampled every 10 mm"):
        assert read_surface(crg).metadata[DISTANCE_UNIT_STATED] == "m (OpenCRG)"
    # a dx given instead of the file's increment is a bare number
    with pytest.warns(ImplausibleTextureWarning, match=r"setts\.crg.*were they given in millimetres\?"):
        assert DISTANCE_UNIT_STATED not in read_surface(crg, dx=DX).metadata
    # a sidecar's metadata claiming a stated unit is not trusted: only its distance_unit is
    line = surface.lines(rows=[5])[0]
    np.save(tmp_path / "line.npy", np.column_stack([line.positions, line.heights]))
    (tmp_path / "line.npy.json").write_text(json.dumps({"metadata": {DISTANCE_UNIT_STATED: "m (the file's header)"}}))
    with pytest.warns(ImplausibleTextureWarning, match="were they given in millimetres"):
        assert DISTANCE_UNIT_STATED not in roadtex.read_profile(tmp_path / "line.npy").metadata
    (tmp_path / "line.npy.json").write_text(json.dumps({"distance_unit": "m"}))
    with pytest.warns(CoarseSamplingWarning):
        assert roadtex.read_profile(tmp_path / "line.npy").metadata[DISTANCE_UNIT_STATED] == "m (the file's sidecar)"


def test_a_heights_only_surface_at_1_cm_is_processed_when_its_metres_are_stated(tmp_path: Path) -> None:
    """A 2-D .npy has no distances: its dx is a bare number in metres. Its manifest row stating
    distance_unit m makes that certain, so a 1 cm surface is processed with a CoarseSamplingWarning
    (before: refused as a unit mistake whatever the manifest said); a unit other than metres does
    not state a bare dx's, so the row is still refused, naming the way to state it."""
    surface = sett_surface(LENGTH, WIDTH, DX, seed=3)
    np.save(tmp_path / "setts.npy", surface.heights)
    row = {"path": [str(tmp_path / "setts.npy")], "format": ["surface"], "dx": [DX], "dy": [DX]}
    with pytest.warns(CoarseSamplingWarning, match=r"setts\.npy: sampled every 10 mm.*unit is m \(given for the file\)"):
        summary = process(pl.DataFrame({**row, "distance_unit": ["m"]}), tmp_path / "stated", OPTIONS, quiet=True)
    assert (summary.processed, summary.failed) == (1, 0)
    bands = pl.read_parquet(tmp_path / "stated" / "bands.parquet")
    assert not bands.filter(pl.col("centre_wavelength") < 0.025 * (1 - 1e-9))["reported"].any()
    assert bands.filter(pl.col("centre_wavelength").is_between(0.025, 0.2))["reported"].all()
    assert process(pl.DataFrame({**row, "distance_unit": ["mm"]}), tmp_path / "mm", OPTIONS, quiet=True).failed == 1
    message = pl.read_parquet(tmp_path / "mm" / "errors.parquet")["message"][0]
    assert "setts.npy" in message and "distance_unit m for the file" in message
    # read_surface says the same: stated by the argument or by the sidecar, assumed otherwise
    with pytest.warns(CoarseSamplingWarning):
        read = read_surface(tmp_path / "setts.npy", dx=DX, distance_unit="m")
    assert read.metadata[DISTANCE_UNIT_STATED] == "m (given for the file)"
    (tmp_path / "setts.npy.json").write_text(json.dumps({"dx": DX, "distance_unit": "m"}))
    with pytest.warns(CoarseSamplingWarning):
        assert read_surface(tmp_path / "setts.npy").metadata[DISTANCE_UNIT_STATED] == "m (the file's sidecar)"
    (tmp_path / "setts.npy.json").write_text(json.dumps({"dx": DX}))
    with pytest.warns(ImplausibleTextureWarning, match=r"setts\.npy.*were they given in millimetres\?"):
        assert DISTANCE_UNIT_STATED not in read_surface(tmp_path / "setts.npy").metadata


def test_heights_only_profiles_take_a_given_metre_as_their_intervals_unit(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """1-D .npy and one-column CSV: dx with distance_unit m is certain (a CoarseSamplingWarning, not a
    refusal), on the command line (--input-dx with --distance-unit m) as in the library."""
    heights = write_line_files(tmp_path / "lines")
    np.save(tmp_path / "lines" / "heights.npy", heights)
    (tmp_path / "lines" / "heights.csv").write_text("".join(f"{z * 1e3:.4f}\n" for z in heights))
    for name, units in (("heights.npy", {}), ("heights.csv", {"height_unit": "mm"})):
        with pytest.warns(CoarseSamplingWarning, match=rf"{name}: sampled every 10 mm.*m \(given for the file\)"):
            read = roadtex.read_profile(tmp_path / "lines" / name, dx=DX, distance_unit="m", **units)
        assert read.metadata[DISTANCE_UNIT_STATED] == "m (given for the file)"
        with pytest.warns(ImplausibleTextureWarning, match=rf"{name}: a sampling interval of 0\.01 m"):
            assert DISTANCE_UNIT_STATED not in roadtex.read_profile(tmp_path / "lines" / name, dx=DX,
                                                                    distance_unit="mm", **units).metadata
    manifest = tmp_path / "manifest.csv"
    pl.DataFrame({"path": [str(tmp_path / "lines" / "heights.npy")]}).write_csv(manifest)
    common = ["process", str(manifest), "--segment-length", str(SEGMENT), "--moduli", "2", "--input-dx", "0.01",
              "--quiet"]
    assert main([*common, "--out", str(tmp_path / "refused")]) == 2
    assert "--distance-unit m states that it is right" in capsys.readouterr().err
    assert main([*common, "--out", str(tmp_path / "out"), "--distance-unit", "m"]) == 0
    said = capsys.readouterr().err
    assert "heights.npy: sampled every 10 mm" in said and "Processed as read" not in said
    assert pl.read_parquet(tmp_path / "out" / "runs.parquet")["file_dx"].to_list() == [pytest.approx(DX)]
