"""The bulk job judges each line run's heights once (plausible road texture in metres?).

Every function taking heights warns when they cannot be road texture in metres
(:func:`roadtex.profiles.plausibility.warn_if_implausible_texture`). Inside the bulk job that
judgement was repeated by the reader, the MPD, the contact model and every spectrum on the same
heights, a fifth of the job's Python time; :func:`judged_once` silences those repeats where the job
has judged the run itself (and refuses it when implausible).
"""

from __future__ import annotations

import threading
import traceback
import warnings
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex.demo import write_synthetic_archive
from roadtex.errors import ImplausibleTextureWarning
from roadtex.profiles import plausibility
from roadtex.profiles.plausibility import judged_once
from roadtex.profiles.synthetic import self_affine_profile

DX = 5e-4


def millimetre_heights() -> np.ndarray:
    """A road-like profile in metres, times 1000: heights in mm passed as metres."""
    return 1000 * self_affine_profile(2000, 2000 * DX, rms_slope=0.3, seed=4)


def warn_on_mm() -> None:
    roadtex.contact(millimetre_heights(), DX, 2.5e6, 2e5, max_iterations=1, raise_on_nonconvergence=False)


def test_judged_once_silences_the_warning_only_inside_and_only_in_its_thread() -> None:
    with pytest.warns(ImplausibleTextureWarning):
        warn_on_mm()
    # inside: silent (the filter turns the warning into an error)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleTextureWarning)
        with judged_once():
            warn_on_mm()
            # another thread is not silenced by this one's block
            caught: list[type[Warning]] = []

            def other() -> None:
                with warnings.catch_warnings(record=True) as record:
                    warnings.simplefilter("always")
                    warn_on_mm()
                caught.extend(w.category for w in record)

            thread = threading.Thread(target=other)
            thread.start()
            thread.join()
            assert ImplausibleTextureWarning in caught
    # after the block, and after a block left by an exception, it warns again
    with pytest.warns(ImplausibleTextureWarning):
        warn_on_mm()
    with pytest.raises(RuntimeError), judged_once():
        raise RuntimeError("left early")
    with pytest.warns(ImplausibleTextureWarning):
        warn_on_mm()


def test_the_job_judges_line_runs_itself_and_still_refuses_millimetres(tmp_path: Path,
                                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """On a small archive with one run in mm, the warning path judges no run's heights while the
    job processes a line run or plans (it did some ten times per run before; the job's own
    comparison profiles are still judged), and the mm run is still refused, naming the file and
    the unit."""
    manifest_path = write_synthetic_archive(tmp_path / "archive", kinds=("dense_asphalt",), runs_per_kind=2, run_length=2.0)
    folder = manifest_path.parent
    manifest = pl.read_csv(manifest_path)
    bad = folder / manifest["path"][1]
    table = pl.read_parquet(bad)
    table.with_columns(pl.col("height_m") * 1000).write_parquet(bad)
    calls: list[str] = []
    judge = plausibility.implausible_texture

    def counting(heights, dx, name, **kwargs):  # noqa: ANN001, ANN202 - a spy with the judged function's signature
        stages = {frame.name for frame in traceback.extract_stack()} & {"process_run", "plan_job"}
        calls.extend(stages)
        return judge(heights, dx, name, **kwargs)

    monkeypatch.setattr(plausibility, "implausible_texture", counting)
    options = roadtex.ProcessingOptions(youngs_moduli=(2e6, 5e6))  # with the error budget's pilot
    summary = roadtex.process(manifest_path, tmp_path / "out", options, quiet=True)
    assert calls == []
    assert (summary.processed, summary.failed) == (1, 1)
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet")
    assert errors["run_id"].to_list() == [manifest["run_id"][1]]
    assert errors["stage"].to_list() == ["read"]
    assert bad.name in errors["message"][0] and "millimetres" in errors["message"][0]
