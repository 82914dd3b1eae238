"""3D surfaces (issue 17, the parts without the areal solver): readers, conditioning, lines,
tiles and stitching, synthetic surfaces."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex.errors import InvalidInputError, MissingDependencyError, ProfileFormatError
from roadtex.profiles import Profile, mpd
from roadtex.surfaces import Surface, read_surface, synthetic_surface
from roadtex.surfaces.conditioning import spike_mask

RNG = np.random.default_rng(17)


def grid_surface(ny: int = 6, nx: int = 8, dx: float = 0.5e-3, dy: float = 1e-3) -> Surface:
    return Surface(RNG.normal(0.0, 1e-3, (ny, nx)), dx, dy)


def long_table(z: np.ndarray, dx: float, dy: float, x0: float = 0.0, y0: float = 0.0) -> tuple[np.ndarray, ...]:
    """Rows (x, y, z) of a grid in shuffled order, without the NaN nodes."""
    iy, ix = np.nonzero(~np.isnan(z))
    order = RNG.permutation(iy.size)
    return x0 + dx * ix[order], y0 + dy * iy[order], z[iy[order], ix[order]]


# --- readers --------------------------------------------------------------------------------------

def test_npy_round_trips_with_spacings_and_units(tmp_path: Path) -> None:
    z = RNG.normal(0.0, 1.0, (5, 7))
    z[2, 3] = np.nan
    np.save(tmp_path / "s.npy", z)
    surface = read_surface(tmp_path / "s.npy", dx=0.5e-3, dy=2e-3, height_unit="mm")
    np.testing.assert_array_equal(surface.heights, z * 1e-3)
    assert (surface.dx, surface.dy, surface.shape) == (0.5e-3, 2e-3, (5, 7))
    assert surface.metadata["source"] == "s.npy" and "read_surface('s.npy'" in surface.history[-1]
    assert read_surface(tmp_path / "s.npy", dx=1e-3).dy == 1e-3      # dy defaults to dx


def test_npy_without_dx_or_not_2d_is_refused_naming_the_file(tmp_path: Path) -> None:
    np.save(tmp_path / "flat.npy", np.zeros((3, 4)))
    with pytest.raises(InvalidInputError, match=r"flat\.npy.*dx"):
        read_surface(tmp_path / "flat.npy")
    np.save(tmp_path / "line.npy", np.zeros(10))
    with pytest.raises(ProfileFormatError, match=r"line\.npy.*2-D"):
        read_surface(tmp_path / "line.npy", dx=1e-3)
    (tmp_path / "broken.npy").write_bytes(b"\x93NUMPY garbage")
    with pytest.raises(ProfileFormatError, match=r"broken\.npy"):
        read_surface(tmp_path / "broken.npy", dx=1e-3)


def test_parquet_long_table_round_trips_with_units_from_the_header(tmp_path: Path) -> None:
    z = RNG.normal(0.0, 1e-3, (4, 6))
    z[1, 2] = np.nan                                           # a node without a row: a drop-out
    x, y, h = long_table(z, 0.5e-3, 1e-3, x0=2.0, y0=-0.1)
    pl.DataFrame({"x (mm)": x * 1e3, "y (mm)": y * 1e3, "z (um)": h * 1e6}).write_parquet(tmp_path / "s.parquet")
    surface = read_surface(tmp_path / "s.parquet")
    np.testing.assert_allclose(surface.heights, z, rtol=1e-12, atol=1e-18)
    assert np.isnan(surface.heights[1, 2]) and np.isnan(surface.heights).sum() == 1
    assert surface.dx == pytest.approx(0.5e-3, rel=1e-12) and surface.dy == pytest.approx(1e-3, rel=1e-12)
    assert surface.x0 == pytest.approx(2.0) and surface.y0 == pytest.approx(-0.1)


def test_csv_long_table_round_trips_with_a_null_height(tmp_path: Path) -> None:
    z = RNG.normal(0.0, 1e-3, (3, 5))
    x, y, h = long_table(z, 1e-3, 2e-3)
    lines = ["# site: test", "distance_m;lateral_m;height_mm"]
    lines += [f"{a:.17g};{b:.17g};{c * 1e3:.17g}" for a, b, c in zip(x, y, h)]
    lines[2] = lines[2].rsplit(";", 1)[0] + ";"                   # an empty height: a drop-out
    (tmp_path / "s.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    surface = read_surface(tmp_path / "s.csv")
    ix, iy = int(round(x[0] / 1e-3)), int(round(y[0] / 2e-3))
    expected = z.copy()
    expected[iy, ix] = np.nan
    np.testing.assert_allclose(surface.heights, expected, rtol=1e-12)
    assert surface.shape == (3, 5)


def test_a_table_off_a_grid_or_with_duplicates_is_refused_naming_the_file(tmp_path: Path) -> None:
    x = np.array([0.0, 1.0, 2.0, 0.0, 1.0, 2.7]) * 1e-3
    y = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0]) * 1e-3
    pl.DataFrame({"x_m": x, "y_m": y, "z_m": np.zeros(6)}).write_parquet(tmp_path / "scatter.parquet")
    with pytest.raises(ProfileFormatError, match=r"scatter\.parquet: not a regular grid"):
        read_surface(tmp_path / "scatter.parquet")
    x[-1] = 1e-3
    pl.DataFrame({"x_m": x, "y_m": y, "z_m": np.zeros(6)}).write_parquet(tmp_path / "twice.parquet")
    with pytest.raises(ProfileFormatError, match=r"twice\.parquet: duplicate"):
        read_surface(tmp_path / "twice.parquet")
    pl.DataFrame({"x": x, "y": y, "z": np.zeros(6)}).write_parquet(tmp_path / "nounit.parquet")
    with pytest.raises(ProfileFormatError, match=r"nounit\.parquet.*unit"):
        read_surface(tmp_path / "nounit.parquet")
    pl.DataFrame({"a": x, "b": y}).write_parquet(tmp_path / "columns.parquet")
    with pytest.raises(ProfileFormatError, match=r"columns\.parquet: no x column"):
        read_surface(tmp_path / "columns.parquet")


def test_missing_empty_and_unknown_format_are_clear(tmp_path: Path) -> None:
    with pytest.raises(ProfileFormatError, match="no such file"):
        read_surface(tmp_path / "absent.npy", dx=1e-3)
    (tmp_path / "empty.csv").write_bytes(b"")
    with pytest.raises(ProfileFormatError, match=r"empty\.csv is empty"):
        read_surface(tmp_path / "empty.csv")
    with pytest.raises(InvalidInputError, match="unknown surface format"):
        read_surface(tmp_path / "empty.csv", format="stl")


@pytest.mark.parametrize("fmt, atol", [("KRBI", 1e-9), ("LRFI", 1e-7)])   # binary; ASCII (8 digits)
def test_crg_round_trips_through_pycrg(tmp_path: Path, fmt: str, atol: float) -> None:
    pycrg = pytest.importorskip("pycrg")
    nu, nv = 40, 9
    z = RNG.normal(0.0, 1e-3, (nu, nv))                     # OpenCRG's (cross sections, long sections)
    v = -0.004 + 1e-3 * np.arange(nv)
    pycrg.write(tmp_path / "road.crg", z, 0.5e-3, v, 0.0, mods={}, comment="roadtex test", fmt=fmt)
    surface = read_surface(tmp_path / "road.crg")
    assert surface.shape == (nv, nu)
    np.testing.assert_allclose(surface.heights, z.T, rtol=0, atol=atol)   # OpenCRG keeps single precision
    assert surface.dx == pytest.approx(0.5e-3, rel=1e-6) and surface.dy == pytest.approx(1e-3, rel=1e-6)
    assert surface.y0 == pytest.approx(-0.004, abs=1e-9) and surface.metadata["crg_data_format"] == fmt
    (tmp_path / "bad.crg").write_text("$CT\nnot really a crg file\n$\n", encoding="ascii")
    with pytest.raises(ProfileFormatError, match=r"bad\.crg"):
        read_surface(tmp_path / "bad.crg")


def test_crg_without_pycrg_is_a_missing_dependency(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "road.crg").write_text("$CT\n$\n", encoding="ascii")
    monkeypatch.setitem(sys.modules, "pycrg", None)            # import pycrg now raises ImportError
    with pytest.raises(MissingDependencyError, match=r"road\.crg.*pip install pycrg") as caught:
        read_surface(tmp_path / "road.crg")
    assert isinstance(caught.value, ImportError)


# --- conditioning ---------------------------------------------------------------------------------

def test_plane_removal_removes_an_exact_plane_and_keeps_drop_outs() -> None:
    ny, nx, dx, dy = 30, 50, 0.5e-3, 1e-3
    y, x = np.mgrid[0:ny, 0:nx]
    z = 3e-3 + 0.02 * (1.0 + dx * x) - 0.05 * (0.2 + dy * y)
    z[4, 7] = z[20, 33] = np.nan
    flat = Surface(z, dx, dy, x0=1.0, y0=0.2).remove_plane()
    assert np.nanmax(np.abs(flat.heights)) < 1e-15
    assert np.isnan(flat.heights[4, 7]) and np.isnan(flat.heights[20, 33])
    texture = RNG.normal(0.0, 1e-3, (ny, nx))
    texture -= texture.mean()
    kept = Surface(texture + np.nan_to_num(z), dx, dy).remove_plane().heights
    # what is left is orthogonal to the plane's three functions
    for basis in (np.ones_like(x), x, y):
        assert abs(float(np.sum(kept * basis))) < 1e-12


def test_resampling_averages_each_rectangle_of_valid_readings() -> None:
    z = RNG.normal(0.0, 1e-3, (4, 6))
    z[0, 1] = np.nan
    coarse = Surface(z, 0.5e-3, 1e-3).resample(1e-3, 2e-3)
    blocks = z.reshape(2, 2, 3, 2).transpose(0, 2, 1, 3).reshape(2, 3, 4)
    np.testing.assert_allclose(coarse.heights, np.nanmean(blocks, axis=2), rtol=1e-14)
    assert coarse.shape == (2, 3) and (coarse.dx, coarse.dy) == (1e-3, 2e-3)
    assert coarse.x[0] == pytest.approx(0.25e-3) and coarse.y[0] == pytest.approx(0.5e-3)   # cell centres
    same = Surface(z, 0.5e-3, 1e-3).resample(0.5e-3, 1e-3)
    np.testing.assert_array_equal(same.heights, z)


def test_fill_dropouts_is_linear_along_rows_and_across_for_empty_rows() -> None:
    y, x = np.mgrid[0:8, 0:10].astype(float)
    z = 1e-3 * (0.3 * x - 0.7 * y + 0.1 * x * y)                 # linear along each row and each column
    holed = z.copy()
    holed[2, 3:6] = np.nan
    holed[5, :] = np.nan
    filled = Surface(holed, 1e-3, 1e-3).fill_dropouts()
    np.testing.assert_allclose(filled.heights, z, rtol=0, atol=1e-18)
    assert "1 empty rows across" in filled.history[-1]


@pytest.mark.parametrize("dx", [0.5e-3, 0.1e-3])
def test_spikes_are_found_and_straight_stone_edges_kept(dx: float) -> None:
    ny, nx = int(0.01 / dx), int(0.02 / dx)
    y, x = np.mgrid[0:ny, 0:nx]
    z = 0.5e-3 * np.sin(2 * np.pi * x * dx / 0.02) * np.cos(2 * np.pi * y * dx / 0.015)
    # a 2 mm cliff across the road, a 2 mm ridge along it running up to the cliff's top, and a
    # square 2 mm stone: straight edges, concave and convex right-angled corners
    z = z + np.where((x * dx > 0.012) | ((y * dx > 0.004) & (y * dx < 0.006)), 2e-3, 0.0)
    z = z + np.where((np.abs(x * dx - 0.006) < 0.002) & (np.abs(y * dx - 0.0075) < 0.0015), 2e-3, 0.0)
    spikes = [(ny // 3, nx // 5), (2, nx - 3)]
    for iy, ix in spikes:
        z[iy, ix] += 3e-3
    mask = spike_mask(Surface(z, dx, dx), 3.0)
    assert sorted(map(tuple, np.argwhere(mask))) == sorted(spikes)
    cleaned = Surface(z, dx, dx).remove_spikes()
    assert np.isnan(cleaned.heights).sum() == 2 and "2 readings" in cleaned.history[-1]


def test_synthetic_surfaces_have_no_spikes_at_fine_sampling() -> None:
    for kind in ("dense_asphalt", "porous_asphalt", "surface_dressing", "cement_concrete"):
        surface = synthetic_surface(kind, 0.05, 0.02, 0.1e-3, seed=3)
        assert spike_mask(surface, 3.0).sum() == 0, kind


# --- lines and tiles ------------------------------------------------------------------------------

def test_lines_are_the_rows() -> None:
    surface = Surface(RNG.normal(0.0, 1e-3, (10, 30)), 0.5e-3, 2e-3, {"site": "A"}, ("made",), x0=1.0, y0=0.1)
    lines = surface.lines()
    assert len(lines) == 10 and all(isinstance(p, Profile) for p in lines)
    for row, profile in enumerate(lines):
        np.testing.assert_array_equal(profile.heights, surface.heights[row])
        np.testing.assert_allclose(profile.positions, 1.0 + 0.5e-3 * np.arange(30))
        assert profile.dx == 0.5e-3 and profile.metadata["row"] == row and profile.metadata["site"] == "A"
        assert profile.metadata["y"] == pytest.approx(0.1 + row * 2e-3)
    assert [p.metadata["row"] for p in surface.lines(every=4)] == [0, 4, 8]
    assert [p.metadata["row"] for p in surface.lines(rows=[3, -1])] == [3, 9]
    assert [p.metadata["row"] for p in surface.lines(wheel_paths=[0.1049, 0.1179])] == [2, 9]
    with pytest.raises(InvalidInputError, match="outside"):
        surface.lines(wheel_paths=[0.5])
    with pytest.raises(InvalidInputError, match="at most one"):
        surface.lines(rows=[1], every=2)


@pytest.mark.parametrize("overlap", [0.0, 2e-3, (3e-3, 1e-3)])
def test_tiles_cover_the_surface_and_stitch_back_exactly(overlap) -> None:
    surface = Surface(RNG.normal(0.0, 1e-3, (23, 61)), 0.5e-3, 0.5e-3)
    tiles = surface.tiles(0.008, 0.004, overlap, detrend=False)
    assert tiles.heights.shape[1:] == (8, 16)
    covered = np.zeros(surface.shape, dtype=int)
    for tile, r0, c0 in zip(tiles.heights, tiles.row_starts, tiles.column_starts):
        covered[r0:r0 + 8, c0:c0 + 16] += 1
        np.testing.assert_array_equal(tile, surface.heights[r0:r0 + 8, c0:c0 + 16])
    assert covered.min() >= 1
    np.testing.assert_allclose(tiles.stitch(tiles.heights), surface.heights, rtol=1e-14, atol=0)
    detrended = surface.tiles(0.008, 0.004, overlap)
    plane_free = detrended.heights.mean(axis=(1, 2))
    assert np.max(np.abs(plane_free)) < 1e-18
    np.testing.assert_allclose(detrended.stitch(detrended.heights, add_trend=True), surface.heights,
                               rtol=1e-12, atol=1e-18)


def test_stitching_cross_fades_smooth_data_without_seams() -> None:
    dx = 0.5e-3
    ny, nx = 60, 200
    y, x = np.mgrid[0:ny, 0:nx] * dx
    smooth = 1e-3 * np.sin(2 * np.pi * x / 0.05) * np.cos(2 * np.pi * y / 0.04)
    surface = Surface(smooth, dx, dx)
    tiles = surface.tiles(0.02, 0.01, 0.005, detrend=False)
    offsets = 1e-5 * RNG.uniform(-1.0, 1.0, len(tiles))       # each tile's own error, as a solver leaves it
    stitched = tiles.stitch(tiles.heights + offsets[:, None, None])
    residual = stitched - smooth
    ramp = 0.005 / dx
    jump = 2e-5                                                # the largest step between two tiles' offsets
    assert np.max(np.abs(np.diff(residual, axis=1))) <= 2 * jump / ramp
    assert np.max(np.abs(np.diff(residual, axis=0))) <= 2 * jump / ramp
    # away from every overlap a tile's values are its own
    first = tiles.heights[0] + offsets[0]
    np.testing.assert_allclose(stitched[:5, :20], first[:5, :20], rtol=1e-14)


def test_tiles_refuse_drop_outs_and_oversize() -> None:
    surface = grid_surface()
    with pytest.raises(InvalidInputError, match="exceeds"):
        surface.tiles(1.0, 1e-3)
    holed = Surface(np.where(np.eye(6, 8) > 0, np.nan, surface.heights), surface.dx, surface.dy)
    with pytest.raises(InvalidInputError, match="fill_dropouts"):
        holed.tiles(2e-3, 2e-3)


# --- synthetic surfaces ---------------------------------------------------------------------------

RANGES = [
    ("dense_asphalt", {}, (0.5, 1.0)),
    ("porous_asphalt", {}, (1.2, 2.0)),
    ("surface_dressing", {}, (1.5, 3.0)),
    ("cement_concrete", {}, (0.3, 0.6)),
    ("cement_concrete", {"tining": True}, (0.6, 1.2)),
]


@pytest.mark.parametrize("kind, options, mpd_range", RANGES, ids=[f"{k}{'-tined' if o else ''}" for k, o, _ in RANGES])
@pytest.mark.parametrize("seed", [0, 1])
def test_synthetic_surface_lines_have_mpd_in_the_line_generators_range(kind, options, mpd_range, seed) -> None:
    surface = synthetic_surface(kind, 1.0, 0.1, 0.5e-3, seed=seed, **options)
    values = [mpd(line).mpd for line in surface.lines(every=20)]
    low, high = mpd_range
    assert low * 1e-3 <= float(np.mean(values)) <= high * 1e-3


def test_synthetic_surfaces_are_reproducible_by_seed() -> None:
    a = synthetic_surface("dense_asphalt", 0.1, 0.03, 0.5e-3, seed=4)
    b = synthetic_surface("dense_asphalt", 0.1, 0.03, 0.5e-3, seed=4)
    c = synthetic_surface("dense_asphalt", 0.1, 0.03, 0.5e-3, seed=5)
    np.testing.assert_array_equal(a.heights, b.heights)
    assert np.max(np.abs(a.heights - c.heights)) > 1e-4
    assert a.shape == (60, 200) and not np.isnan(a.heights).any() and abs(a.heights.mean()) < 1e-14
    assert a.metadata["kind"] == "dense_asphalt" and a.metadata["seed"] == 4
    # lines are textured along and correlated across at the stone scale, not copies of each other
    rows = a.heights
    assert 0.2 < np.corrcoef(rows[10], rows[11])[0, 1] < 0.999
    with pytest.raises(InvalidInputError, match="unknown pavement kind"):
        synthetic_surface("gravel", 0.1, 0.03, 0.5e-3)


def test_tined_concrete_grooves_run_across_the_road() -> None:
    tined = synthetic_surface("cement_concrete", 0.3, 0.05, 0.5e-3, seed=0, tining=True)
    across = np.mean(np.std(tined.heights, axis=0))           # along a column: across the road
    along = np.mean(np.std(tined.heights, axis=1))
    assert along > 1.5 * across


def test_surface_api_is_exported_from_the_package_root() -> None:
    assert roadtex.Surface is Surface and roadtex.read_surface is read_surface
    assert roadtex.synthetic_surface is synthetic_surface


def test_porous_asphalt_surface_is_negative_texture_unlike_the_others() -> None:
    # negative texture: a plateau of stone tops with deep pores, heights skewed downwards
    def skewness(kind: str) -> float:
        z = synthetic_surface(kind, 0.5, 0.1, 0.25e-3, seed=0).heights
        return float(np.mean((z - z.mean()) ** 3) / np.mean((z - z.mean()) ** 2) ** 1.5)

    assert skewness("porous_asphalt") < -0.8
    for kind in ("dense_asphalt", "surface_dressing", "cement_concrete"):
        assert skewness(kind) > -0.3, kind


def test_surface_refuses_what_is_not_a_surface() -> None:
    with pytest.raises(InvalidInputError, match="2-D"):
        Surface(np.zeros(10), 1e-3, 1e-3)
    with pytest.raises(InvalidInputError, match="inf at row 1, column 2"):
        Surface(np.where(np.arange(12).reshape(3, 4) == 6, np.inf, 0.0), 1e-3, 1e-3)
    with pytest.raises(InvalidInputError, match="all heights are NaN"):
        Surface(np.full((2, 3), np.nan), 1e-3, 1e-3)
    with pytest.raises(InvalidInputError, match="dy"):
        Surface(np.zeros((2, 3)), 1e-3, -1.0)
    surface = grid_surface()
    with pytest.raises(ValueError):
        surface.heights[0, 0] = 1.0                           # read-only: steps return new surfaces
