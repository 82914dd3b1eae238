"""Plotting functions and the report's benchmark figure with NaN or infinite figures (issue 38):
a clear InvalidInputError naming what is wrong, or drawn with what was left out said on the axes;
never numpy's, polars' or matplotlib's own exception (before: "Axis limits cannot be NaN or Inf",
"Data cannot be log-scaled", polars' ComputeError, "cannot convert float NaN to integer")."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib
import numpy as np
import polars as pl
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from roadtex import plot  # noqa: E402
from roadtex.errors import InvalidInputError  # noqa: E402
from roadtex.report.document import read_benchmark  # noqa: E402

Z = np.random.default_rng(0).normal(0.0, 1e-3, 200)
S = np.random.default_rng(1).normal(0.0, 1e-3, (20, 30))


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


@pytest.mark.parametrize("call, words", [
    (lambda: plot.profile(np.r_[Z[:-1], np.inf], 1e-3), r"heights holds 1 infinite value\(s\), the first at index \(199,\)"),
    (lambda: plot.profile(Z, 1e-3, pressure=np.r_[np.zeros(199), np.inf]), "pressure holds 1 infinite"),
    (lambda: plot.profile(Z, 1e-3, envelope={2e6: np.r_[Z[:-1], -np.inf]}), "envelope holds 1 infinite"),
    (lambda: plot.profile(Z, float("inf")), "dx must be a positive finite number"),
    (lambda: plot.profile(Z, 1e-3, x0=float("inf")), "x0 must be finite"),
    (lambda: plot.profile(Z, 1e-3, window=float("nan")), "window must be a positive finite number"),
    (lambda: plot.profile(Z, "1e-3"), "dx must be a number"),
    (lambda: plot.surface_map(np.where(S > 2e-3, np.inf, S), 1e-3), "values holds .* infinite"),
    (lambda: plot.surface_map(S, float("inf")), "dx must be a positive finite number"),
    (lambda: plot.surface_map(S, 1e-3, x0=float("nan")), "x0 must be finite"),
    (lambda: plot.speed_vs_error([{"solver": "a", "case": "b", "l1_error": "x", "time_s": "1"}]),
     "l1_error must be numbers, got String"),
    (lambda: plot.speed_vs_error(5), "speed rows must be a table or a list of objects"),
])
def test_non_finite_or_wrong_figures_are_a_clear_error(call, words: str) -> None:
    with pytest.raises(InvalidInputError, match=words):
        call()


def test_nan_heights_are_drawn_as_gaps() -> None:
    fig, ax = plot.profile(np.r_[Z[:100], np.full(100, np.nan)], 1e-3)
    assert np.isnan(ax.lines[0].get_ydata()).sum() == 100


def test_speed_rows_that_a_log_axis_cannot_draw_are_counted_on_it() -> None:
    rows = json.loads('{"rows": [{"solver": "a", "case": "westergaard", "l1_error": Infinity, "time_s": 1.0},'
                      '{"solver": "a", "case": "westergaard", "l1_error": NaN, "time_s": 0.5},'
                      '{"solver": "a", "case": "westergaard", "l1_error": 0.01, "time_s": -Infinity},'
                      '{"solver": "b", "case": "self_affine", "l1_error": 0.001, "time_s": 0.002}]}')["rows"]
    fig, ax = plot.speed_vs_error(rows)
    fig.canvas.draw()
    assert sum(len(c.get_offsets()) for c in ax.collections) == 1
    assert any("3 of 4 rows not drawn" in t.get_text() for t in ax.texts)
    assert plot.speed_vs_error(rows[:3]) == (None, None)   # nothing drawable: no figure, as with no rows


def test_a_non_finite_stated_error_draws_no_bar_and_is_said() -> None:
    bands = pl.DataFrame({"band": [30, 31, 32], "label": ["a", "b", "c"], "texture_level": [40.0, 42.0, 38.0],
                          "enveloped_level": [35.0, 36.0, 30.0], "youngs_modulus": [2e6] * 3,
                          "level_error_db": [0.1, float("inf"), 0.2]})
    fig, (top, _) = plot.band_levels(bands)
    fig.canvas.draw()
    assert any("1 row(s) with a non-finite stated error" in t.get_text() for t in top.texts)
    assert all(np.isfinite(top.get_ylim()))


@pytest.mark.parametrize("text, words", [
    ("{not json", "not readable JSON"), ("[1, 2]", r"expected an object with a list of rows .*, got list"),
    ('{"rows": 5}', "expected an object with a list of rows"),
])
def test_a_benchmark_file_that_is_not_the_benches_json_is_named(tmp_path: Path, text: str, words: str) -> None:
    (tmp_path / "bench.json").write_text(text, encoding="utf-8")
    with pytest.raises(InvalidInputError, match=rf"benchmark bench\.json: {words}"):
        read_benchmark(tmp_path / "bench.json")
