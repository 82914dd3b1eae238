"""Long survey runs in metres are road texture, grades and vertical curves included.

The plausibility check (heights in mm passed as metres?) used to judge a run against one straight
line: a correct 500 m profile over a crest, whose grade changes by 4 %, rises 2.5 m above that line
and was refused by the bulk job as "given in millimetres". Runs are now judged stretch by stretch
(:data:`~roadtex.profiles.plausibility.JUDGED_STRETCH`), which keeps every unit mistake caught.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex.profiles.plausibility import PLAUSIBLE_PEAK_TO_VALLEY, implausible_texture

DX = 1e-3  # m, a coarse but valid texture sampling: keeps the kilometre small


def crest_run(length: float, grade_change: float, *, seed: int = 0) -> np.ndarray:
    """Heights (m) of a run over a parabolic crest: grade +g/2 to -g/2 over ``length`` (m), plus a
    texture of 0.5 mm rms (smoothed white noise, stones of a few mm)."""
    n = int(round(length / DX))
    x = np.arange(n) * DX
    geometry = grade_change / 2 * x - grade_change / (2 * length) * x**2
    noise = np.random.default_rng(seed).standard_normal(n + 8)
    texture = np.convolve(noise, np.ones(9) / 9, mode="valid")[:n]
    return geometry + 0.5e-3 * texture / texture.std()


@pytest.mark.parametrize("length", [200.0, 500.0, 1000.0])
def test_a_crest_in_metres_is_road_and_in_millimetres_is_not(length: float) -> None:
    z = crest_run(length, 0.04)
    x = np.arange(z.size)
    chord = z - np.polyval(np.polyfit(x, z, 1), x)
    if length >= 500:  # what the one-line judgement saw: over its limit
        assert np.ptp(chord) > PLAUSIBLE_PEAK_TO_VALLEY
    assert implausible_texture(z, DX, "run.csv") is None
    reason = implausible_texture(1000 * z, DX, "run.csv")
    assert reason is not None and "millimetres" in reason and "per 1 m stretch" in reason


def test_drop_outs_and_a_missing_metre_are_judged_without_numpy_warnings() -> None:
    """The NaN path (each stretch less its median) on a long run with scattered drop-outs and a
    stretch of 1.5 m without any reading: still road in metres, still mm when scaled, and no
    all-NaN warning from numpy (run threads cannot filter those)."""
    z = crest_run(500.0, 0.04, seed=1)
    rng = np.random.default_rng(2)
    z[rng.random(z.size) < 0.01] = np.nan
    z[100_000:101_500] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert implausible_texture(z, DX, "run.csv") is None
        reason = implausible_texture(1000 * z, DX, "run.csv")
    assert reason is not None and "millimetres" in reason


def test_the_job_processes_a_steep_crest_and_refuses_it_in_millimetres(tmp_path: Path) -> None:
    """120 m over a crest whose grade changes by 8 % (1.2 m above its chord): the job solves the
    run in metres and refuses the same run written in mm as metres, naming the file."""
    z = crest_run(120.0, 0.08, seed=3)
    x = np.arange(z.size) * DX
    good, bad = tmp_path / "crest_m.csv", tmp_path / "crest_mm_as_m.csv"
    pl.DataFrame({"distance_m": x, "height_m": z}).write_csv(good)
    pl.DataFrame({"distance_m": x, "height_m": 1000 * z}).write_csv(bad)
    manifest = pl.DataFrame({"path": [str(good), str(bad)], "run_id": ["metres", "millimetres"]})
    options = roadtex.ProcessingOptions(youngs_moduli=(2.5e6,), tol=1e-6, error_budget_db=None, dx=DX)
    summary = roadtex.process(manifest, tmp_path / "out", options, quiet=True)
    assert (summary.processed, summary.failed) == (1, 1)
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet")
    assert errors["run_id"].to_list() == ["millimetres"]
    assert bad.name in errors["message"][0] and "millimetres" in errors["message"][0]
