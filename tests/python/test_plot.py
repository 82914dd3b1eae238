"""roadtex.plot: what each figure draws is the data given, in the stated units (mm, MPa, dB), with
the stated errors as error bars and equal scales on surface maps; and the report draws with it."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import polars as pl  # noqa: E402
import pytest  # noqa: E402

import roadtex  # noqa: E402
import roadtex.plot  # noqa: E402
from roadtex.errors import InvalidInputError  # noqa: E402


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def solved():
    p = roadtex.synthetic_pavement("dense_asphalt", length=0.1, dx=0.1e-3, seed=1)
    z = p.heights - p.heights.mean()
    batch = roadtex.contact_many(z[None, :], p.dx, youngs_modulus=[2e6, 1e7], mean_pressure=2e5)
    return z, p.dx, {2e6: batch.envelope[0, 0], 1e7: batch.envelope[0, 1]}, {2e6: batch.pressure[0, 0], 1e7: batch.pressure[0, 1]}


def test_profile_draws_heights_envelopes_and_pressures_in_mm_and_mpa(solved) -> None:
    z, dx, envelopes, pressures = solved
    fig, (height_ax, pressure_ax) = roadtex.plot.profile(z, dx, envelope=envelopes, pressure=pressures)
    lines = {line.get_label(): line for line in height_ax.get_lines()}
    assert set(lines) == {"road profile", "E = 2 MPa", "E = 10 MPa"}
    np.testing.assert_allclose(lines["road profile"].get_ydata(), z * 1e3)
    np.testing.assert_allclose(lines["E = 10 MPa"].get_ydata(), envelopes[1e7] * 1e3)
    np.testing.assert_allclose(lines["road profile"].get_xdata(), np.arange(z.size) * dx * 1e3)
    drawn = {line.get_label(): line.get_ydata() for line in pressure_ax.get_lines()}
    np.testing.assert_allclose(drawn["E = 2 MPa"], pressures[2e6] / 1e6)
    assert pressure_ax.get_yscale() == "symlog" and "MPa" in pressure_ax.get_ylabel()
    assert fig.legends, "the legend sits outside the axes, on the figure"


def test_profile_window_shows_the_middle_and_one_envelope_needs_no_modulus(solved) -> None:
    z, dx, envelopes, _ = solved
    fig, ax = roadtex.plot.profile(z, dx, envelope=envelopes[2e6], window=0.02, x0=1.0)
    x = ax.get_lines()[0].get_xdata()
    assert x.size == 200 and x[0] == pytest.approx((1.0 + (z.size - 200) // 2 * dx) * 1e3)
    assert [line.get_label() for line in ax.get_lines()] == ["road profile", "enveloped"]


def test_profile_refuses_an_envelope_of_another_length(solved) -> None:
    z, dx, envelopes, _ = solved
    with pytest.raises(InvalidInputError, match="envelope has shape"):
        roadtex.plot.profile(z, dx, envelope=envelopes[2e6][:-1])


def bands_table() -> pl.DataFrame:
    """Two segments and two moduli of two bands, one band unreported, with stated errors."""
    rows = []
    for segment, (t, e1, e2) in enumerate([(40.0, 35.0, 30.0), (46.0, 37.0, 31.0)]):
        for e, level, err in ((2e6, e1, 0.05 + 0.1 * segment), (1e7, e2, 0.02)):
            rows.append({"run_id": "a", "segment": segment, "youngs_modulus": e, "band": 20, "label": "10",
                         "texture_level": t, "enveloped_level": level, "level_error_db": err, "reported": True})
            rows.append({"run_id": "a", "segment": segment, "youngs_modulus": e, "band": 30, "label": "1",
                         "texture_level": 99.0, "enveloped_level": 99.0, "level_error_db": 9.0, "reported": False})
    return pl.DataFrame(rows)


def test_band_levels_average_in_power_and_show_the_stated_errors() -> None:
    fig, (top, bottom) = roadtex.plot.band_levels(bands_table())
    # only the reported band is drawn
    assert [t.get_text() for t in bottom.get_xticklabels()] == ["10"]
    containers = {c.get_label(): c for c in top.containers}
    assert set(containers) == {"original", "E = 2 MPa", "E = 10 MPa"}
    line, _, (bars,) = containers["E = 2 MPa"]
    # the energetic mean of 35 and 37 dB
    assert line.get_ydata()[0] == pytest.approx(10 * np.log10((10 ** 3.5 + 10 ** 3.7) / 2))
    # the error bar is the mean's: the energetic mean of the rows each raised by its own stated error
    # (35 dB by 0.05, 37 dB by 0.15), less the mean; between the smallest and the largest row error
    segment = bars.get_segments()[0]
    mean = 10 * np.log10((10 ** 3.5 + 10 ** 3.7) / 2)
    raised = 10 * np.log10((10 ** ((35 + 0.05) / 10) + 10 ** ((37 + 0.15) / 10)) / 2)
    assert segment[1][1] - segment[0][1] == pytest.approx(2 * (raised - mean))
    assert 0.05 < raised - mean < 0.15
    original = containers["original"][0].get_ydata()[0]
    assert original == pytest.approx(10 * np.log10((10 ** 4.0 + 10 ** 4.6) / 2))
    difference = {c.get_label(): c[0].get_ydata()[0] for c in bottom.containers}
    assert difference["E = 10 MPa"] == pytest.approx(10 * np.log10((10 ** 3.0 + 10 ** 3.1) / 2) - original)
    assert "dB re 1 µm" in top.get_ylabel()


def test_band_levels_without_errors_or_moduli() -> None:
    table = bands_table().filter(pl.col("youngs_modulus") == 2e6).drop("level_error_db", "youngs_modulus")
    fig, (top, _) = roadtex.plot.band_levels(table)
    labels = [c.get_label() for c in top.containers]
    assert labels == ["original", "enveloped"]
    assert all(not c.has_yerr for c in top.containers)
    nulls = bands_table().with_columns(pl.lit(None, dtype=pl.Float64).alias("level_error_db"))
    _, (top, _) = roadtex.plot.band_levels(nulls)
    assert all(not c.has_yerr for c in top.containers), "no stated error: no bars (not bars of zero)"
    with pytest.raises(InvalidInputError, match="texture_level"):
        roadtex.plot.band_levels(table.drop("texture_level"))


def test_surface_map_has_equal_scales_and_states_units() -> None:
    heights = np.random.default_rng(1).normal(0, 1e-3, (20, 100))
    fig, ax = roadtex.plot.surface_map(heights, 1e-3, 0.5e-3, y0=0.01)
    image = ax.images[0]
    assert ax.get_aspect() == 1.0
    np.testing.assert_allclose(image.get_extent(), [-0.5, 99.5, 9.75, 19.75])
    np.testing.assert_allclose(image.get_array(), heights * 1e3)
    assert image.colorbar.ax.get_ylabel() == "height (mm)"
    _, ax = roadtex.plot.surface_map(np.full((4, 4), 2e5), 1e-3, kind="pressure")
    np.testing.assert_allclose(ax.images[0].get_array(), 0.2)
    with pytest.raises(InvalidInputError, match="kind"):
        roadtex.plot.surface_map(heights, 1e-3, kind="depth")


def test_speed_vs_error_is_log_log_and_leaves_out_rows_without_a_time() -> None:
    rows = [{"solver": "roadtex", "case": "westergaard", "time_s": 0.01, "l1_error": 1e-5},
            {"solver": "tamaas", "case": "westergaard", "time_s": 0.2, "l1_error": 1e-5},
            {"solver": "tamaas", "case": "self_affine", "time_s": None, "l1_error": 1e-6}]
    fig, ax = roadtex.plot.speed_vs_error(rows)
    assert ax.get_xscale() == ax.get_yscale() == "log"
    assert [c.get_label() for c in ax.collections] == ["roadtex (westergaard)", "tamaas (westergaard)"]
    assert roadtex.plot.speed_vs_error(rows[2:]) == (None, None)


def test_the_report_draws_with_roadtex_plot(monkeypatch, tmp_path) -> None:
    from roadtex.demo import write_synthetic_archive
    from roadtex.report import document

    calls: list[str] = []
    for name in ("profile", "band_levels", "surface_map", "speed_vs_error"):
        original = getattr(roadtex.plot, name)

        def spy(*args, _name=name, _original=original, **kwargs):
            calls.append(_name)
            return _original(*args, **kwargs)

        monkeypatch.setattr(roadtex.plot, name, spy)
    manifest = write_synthetic_archive(tmp_path / "archive", kinds=["dense_asphalt"], runs_per_kind=1, run_length=0.6,
                                       surfaces_per_kind=1)
    roadtex.process(manifest, tmp_path / "results", roadtex.ProcessingOptions(youngs_moduli=(2e6,), error_budget_db=None),
                    quiet=True)
    rows = {"rows": [{"solver": "roadtex", "case": "westergaard", "time_s": 0.01, "l1_error": 1e-5}]}
    (tmp_path / "bench.json").write_text(__import__("json").dumps(rows), encoding="utf-8")
    document.build_report(tmp_path / "results", benchmark=tmp_path / "bench.json")
    assert {"profile", "band_levels", "surface_map", "speed_vs_error"} <= set(calls), calls
