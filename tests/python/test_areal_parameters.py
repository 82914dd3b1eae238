"""ISO 25178-2 areal parameters (roadtex.surfaces.areal) against closed forms: a cosine, a 2-D
cosine product, a plane, a two-level surface; and their place in the surface job's outputs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ellipe

from roadtex.errors import InvalidInputError
from roadtex.surfaces import Surface
from roadtex.surfaces.areal import areal_parameters


def grid(rows: int, columns: int, dx: float, dy: float) -> tuple[np.ndarray, np.ndarray]:
    """Sample centres ((i + 1/2) spacing): a grid of whole periods is then symmetric about its middle."""
    y, x = np.meshgrid(dy * (np.arange(rows) + 0.5), dx * (np.arange(columns) + 0.5), indexing="ij")
    return x, y


def test_a_cosine_along_the_road_has_its_closed_forms() -> None:
    amplitude, wavelength, dx, dy = 1e-3, 20e-3, 0.05e-3, 1e-3
    x, _ = grid(8, 2000, dx, dy)          # 5 whole periods, 400 samples a period
    p = areal_parameters(amplitude * np.cos(2 * np.pi * x / wavelength), dx, dy)
    k = 2 * np.pi / wavelength
    assert p["sq"] == pytest.approx(amplitude / math.sqrt(2), rel=1e-9)
    # |cos| summed at the samples: the midpoint rule's error, (k dx)^2 / 24 of it (1e-5 here)
    assert p["sa"] == pytest.approx(2 * amplitude / math.pi, rel=3e-5)
    assert p["ssk"] == pytest.approx(0.0, abs=1e-9)
    assert p["sku"] == pytest.approx(1.5, rel=1e-9)
    # the highest and lowest samples are half a spacing from crest and trough
    crest = amplitude * math.cos(k * dx / 2)
    assert p["sp"] == pytest.approx(crest, rel=1e-9) and p["sv"] == pytest.approx(crest, rel=1e-9)
    assert p["sz"] == pytest.approx(2 * crest, rel=1e-9)
    # RMS slope A k / sqrt 2; developed area (2/pi) sqrt(1 + a^2) E(a^2 / (1 + a^2)) - 1, a = A k
    a = amplitude * k
    assert p["sdq"] == pytest.approx(a / math.sqrt(2), rel=1e-3)
    assert p["sdr"] == pytest.approx(2 / math.pi * math.sqrt(1 + a * a) * ellipe(a * a / (1 + a * a)) - 1, rel=2e-3)


def test_a_product_of_cosines_has_its_closed_forms() -> None:
    amplitude, dx, dy = 0.5e-3, 0.1e-3, 0.1e-3
    kx, ky = 2 * np.pi / 10e-3, 2 * np.pi / 25e-3
    x, y = grid(1000, 1000, dx, dy)       # 10 and 4 whole periods
    p = areal_parameters(Surface(amplitude * np.cos(kx * x) * np.cos(ky * y), dx, dy))
    assert p["sq"] == pytest.approx(amplitude / 2, rel=1e-9)
    assert p["sa"] == pytest.approx(4 * amplitude / math.pi ** 2, rel=3e-4)   # midpoint rule, 100 samples a period
    assert p["ssk"] == pytest.approx(0.0, abs=1e-9)
    assert p["sku"] == pytest.approx(9 / 4, rel=1e-9)    # (3/2)^2 for a product of independent cosines
    assert p["sdq"] == pytest.approx(amplitude / 2 * math.hypot(kx, ky), rel=2e-3)


def test_a_plane_has_every_parameter_zero() -> None:
    x, y = grid(50, 300, 0.2e-3, 0.5e-3)
    p = areal_parameters(2e-3 + 0.01 * x - 0.03 * y, 0.2e-3, 0.5e-3)
    for name in ("sa", "sq", "sp", "sv", "sz"):
        assert abs(p[name]) < 1e-15, name
    # slopes of the rounding left (ulps of 2e-3 m, 4e-19 m) over one spacing (0.2 mm): ~1e-15
    for name in ("sdq", "sdr"):
        assert abs(p[name]) < 1e-14, name
    assert math.isnan(p["ssk"]) and math.isnan(p["sku"])   # undefined on a flat surface, not rounding noise
    # without the F-operation the tilt is texture: slope 0.01 along, -0.03 across
    tilted = areal_parameters(2e-3 + 0.01 * x - 0.03 * y, 0.2e-3, 0.5e-3, remove_plane=False)
    assert tilted["sdq"] == pytest.approx(math.hypot(0.01, 0.03), rel=1e-9)


def test_a_two_level_surface_has_the_skewness_and_kurtosis_of_its_shares() -> None:
    # a pedestal h high on a centred square (share p): Ssk = (1 - 2p) / sqrt(p (1 - p)),
    # Sku = (1 - 3 p (1 - p)) / (p (1 - p)), Sp = h (1 - p), Sv = h p, Sq = h sqrt(p (1 - p))
    h = 2e-3
    z = np.zeros((100, 100))
    z[35:65, 35:65] = h
    p = (30 * 30) / (100 * 100)
    result = areal_parameters(z, 1e-3, 1e-3)
    assert result["ssk"] == pytest.approx((1 - 2 * p) / math.sqrt(p * (1 - p)), rel=1e-9)
    assert result["sku"] == pytest.approx((1 - 3 * p * (1 - p)) / (p * (1 - p)), rel=1e-9)
    assert result["sq"] == pytest.approx(h * math.sqrt(p * (1 - p)), rel=1e-9)
    assert result["sp"] == pytest.approx(h * (1 - p), rel=1e-9) and result["sv"] == pytest.approx(h * p, rel=1e-9)
    assert result["sa"] == pytest.approx(2 * h * p * (1 - p), rel=1e-9)
    # a pit instead of a pedestal mirrors the skewness
    assert areal_parameters(-z, 1e-3, 1e-3)["ssk"] == pytest.approx(-result["ssk"], rel=1e-9)


def test_bad_grids_are_refused() -> None:
    with pytest.raises(InvalidInputError, match="dx and dy"):
        areal_parameters(np.zeros((4, 4)))
    with pytest.raises(InvalidInputError, match="2-D grid"):
        areal_parameters(np.zeros(10), 1e-3, 1e-3)
    with pytest.raises(InvalidInputError, match="valid"):
        areal_parameters(np.full((3, 3), np.nan), 1e-3, 1e-3)


def test_an_infinite_height_is_refused_clearly() -> None:
    z = np.random.default_rng(4).normal(0.0, 1e-3, (6, 9))
    z[2, 5] = -np.inf
    with pytest.raises(InvalidInputError, match=r"1 infinite value\(s\) \(the first at \(2, 5\)\)"):
        areal_parameters(z, 1e-3, 1e-3)


@pytest.mark.parametrize("samples", [4, 5, 6, 8, 10])
def test_slopes_at_scanner_resolution_keep_most_of_a_short_wavelengths_gradient(samples: int) -> None:
    # 1 mm sampling, a wavelength of 4 to 10 samples: central differences kept sin(2 pi/n)/(2 pi/n) of
    # the slope (64 % at 4 samples); two-point differences between readings keep at least 90 %
    amplitude, dx = 0.5e-3, 1e-3
    x, _ = grid(20, samples * 40, dx, dx)
    p = areal_parameters(amplitude * np.cos(2 * np.pi * x / (samples * dx)), dx, dx)
    assert p["sdq"] >= 0.9 * amplitude * (2 * np.pi / (samples * dx)) / math.sqrt(2)


@pytest.mark.parametrize("samples", [4, 6, 8])
def test_sdq_and_sdr_agree_with_surface_topography_at_scanner_resolution(samples: int) -> None:
    """SurfaceTopography (an independent implementation, MIT) computes rms_gradient with two-point
    (upwind) differences by default, the gradient stated in roadtex.surfaces.areal."""
    st = pytest.importorskip("SurfaceTopography", reason="SurfaceTopography is not installed (pip install SurfaceTopography)")
    dx, dy = 1e-3, 1e-3
    x, y = grid(60, 90, dx, dy)
    rng = np.random.default_rng(samples)
    z = (0.6e-3 * np.cos(2 * np.pi * x / (samples * dx)) + 0.3e-3 * np.sin(2 * np.pi * (x + 2 * y) / (samples * 1.5 * dx))
         + rng.normal(0.0, 0.1e-3, x.shape))
    ours = areal_parameters(z, dx, dy, remove_plane=False)
    rows, columns = z.shape
    topography = st.Topography(z.T, physical_sizes=(columns * dx, rows * dy), periodic=False)   # its axes: x first
    assert ours["sdq"] == pytest.approx(topography.rms_gradient(), rel=1e-12)
    slx, sly = topography.derivative(1)
    assert ours["sdr"] == pytest.approx(float(np.mean(np.sqrt(1 + slx ** 2 + sly ** 2) - 1)), rel=1e-12)


def test_the_surface_job_writes_the_parameters_of_the_run_and_of_each_tile(tmp_path) -> None:
    import json

    import polars as pl

    from roadtex.archive import ProcessingOptions, process
    from roadtex.surfaces import synthetic_surface
    from roadtex.surfaces.areal import AREAL_FILTERS

    surface = synthetic_surface("dense_asphalt", 0.4, 0.05, 1e-3, seed=3)
    np.save(tmp_path / "s.npy", surface.heights)
    manifest = pl.DataFrame({"path": [str(tmp_path / "s.npy")], "format": ["surface"], "dx": [1e-3], "dy": [1e-3]})
    options = ProcessingOptions(segment_length=0.2, youngs_moduli=(2e6,), tol=1e-8, error_budget_db=None)
    assert process(manifest, tmp_path / "out", options, quiet=True).failed == 0
    table = pl.read_parquet(tmp_path / "out" / "areal.parquet")
    assert table["scope"].to_list() == ["run", "tile", "tile"] and table["tile"].to_list() == [None, 0, 1]
    assert (table["filters"] == AREAL_FILTERS).all()
    whole = table.row(0, named=True)
    expected = areal_parameters(Surface(surface.heights, 1e-3, 1e-3))
    for name, value in expected.items():
        assert whole[name] == pytest.approx(value, rel=1e-9), name
    assert whole["end"] - whole["start"] == pytest.approx(0.4) and whole["width"] == pytest.approx(0.05, rel=0.05)
    tiles = table.filter(pl.col("scope") == "tile")
    assert (tiles["end"] - tiles["start"]).to_list() == pytest.approx([0.2, 0.2])
    assert json.loads(pl.read_parquet_metadata(tmp_path / "out" / "areal.parquet")["units"])["sdq"] == "1"
