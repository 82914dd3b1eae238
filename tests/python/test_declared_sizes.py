"""Files that declare more values than roadtex reads (roadtex.profiles.readers.limits.MAX_POINTS):
a Parquet footer's rows x columns, a ``.npy`` header's shape, a long table's grid. Each is refused
from what it declares, before its data is read (polars aborts the process on an allocation it
cannot make: nothing could catch it; numpy's MemoryError names no file), as a ProfileFormatError
naming the file; in a job it is that run's failure, planning included. The files here are small:
Parquet null columns declare millions of rows in a few hundred kB, and the ``.npy`` cases lower
the limit instead of writing a sparse 16 GB file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest

from roadtex.archive import ProcessingOptions, process, read_manifest
from roadtex.errors import ManifestError, ProfileFormatError
from roadtex.profiles import read_profile, write_profile
from roadtex.profiles.pavements import synthetic_pavement
from roadtex.profiles.readers import limits
from roadtex.surfaces import read_surface, x3p
from roadtex.surfaces.readers import is_surface_file

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

DX = 5e-4
pytestmark = pytest.mark.filterwarnings("ignore::roadtex.errors.ErrorBudgetWarning")


def declaring(path: Path, rows: int, columns: tuple[str, ...]) -> Path:
    """A Parquet file whose footer declares ``rows`` rows of ``columns`` (null columns: no data)."""
    pq.write_table(pa.table({name: pa.nulls(rows) for name in columns}), path)
    assert path.stat().st_size < 2**20
    return path


def test_the_limit_is_x3ps() -> None:
    assert limits.MAX_POINTS == x3p.MAX_POINTS == 2**27


def test_a_parquet_profile_declaring_too_many_values_is_refused_naming_it(tmp_path: Path) -> None:
    bomb = declaring(tmp_path / "bomb.parquet", limits.MAX_POINTS // 2 + 1, ("distance (m)", "height (m)"))
    with pytest.raises(ProfileFormatError, match=r"^bomb\.parquet: its Parquet metadata \(67,108,865 rows x 2 "
                                                 r"columns\) declares 134,217,730 values, beyond the 134,217,728"):
        read_profile(bomb)


def test_a_parquet_surface_declaring_too_many_values_is_refused_naming_it(tmp_path: Path) -> None:
    bomb = declaring(tmp_path / "points.parquet", limits.MAX_POINTS // 3 + 1, ("x (m)", "y (m)", "z (m)"))
    assert is_surface_file(bomb)   # from its schema, unread
    with pytest.raises(ProfileFormatError, match=r"^points\.parquet: its Parquet metadata .* beyond the 134,217,728"):
        read_surface(bomb)


def test_a_parquet_manifest_declaring_too_many_cells_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    bomb = declaring(tmp_path / "manifest.parquet", 51, ("path", "run_id"))
    monkeypatch.setattr(limits, "MAX_POINTS", 100)
    with pytest.raises(ManifestError, match=r"manifest\.parquet declares 51 rows x 2 columns, beyond the 100 cells"):
        read_manifest(bomb)


def test_a_parquet_bomb_is_one_runs_failure_and_planning_goes_on(tmp_path: Path) -> None:
    good = write_profile(synthetic_pavement("dense_asphalt", 0.6, DX, seed=0), tmp_path / "good.parquet")
    bomb = declaring(tmp_path / "bomb.parquet", limits.MAX_POINTS // 2 + 1, ("distance (m)", "height (m)"))
    rows = pl.DataFrame({"path": [str(bomb), str(good)], "run_id": ["bomb", "good"]})
    options = ProcessingOptions(youngs_moduli=(1e7,), segment_length=0.128, tol=1e-6)   # planned: the pilot reads
    summary = process(rows, tmp_path / "out", options, quiet=True, threads=1)
    assert (summary.processed, summary.failed) == (1, 1)
    errors = pl.read_parquet(tmp_path / "out" / "errors.parquet")
    assert errors["run_id"].to_list() == ["bomb"]
    assert errors["message"][0].startswith("bomb.parquet: its Parquet metadata")


@pytest.mark.parametrize("kind", ["profile", "surface"])
def test_an_npy_declaring_too_many_values_is_refused_unread(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                            kind: str) -> None:
    path = tmp_path / f"{kind}.npy"
    np.save(path, np.zeros(2000) if kind == "profile" else np.zeros((10, 200)))
    monkeypatch.setattr(limits, "MAX_POINTS", 1000)

    def loading(*args: object, **kwargs: object) -> None:
        raise AssertionError("the array was read")

    monkeypatch.setattr(np, "load", loading)
    shape = r"\(2000,\)" if kind == "profile" else r"\(10, 200\)"
    with pytest.raises(ProfileFormatError, match=rf"^{kind}\.npy: its \.npy header's shape {shape} declares 2,000 "
                                                 r"values, beyond the 1,000"):
        (read_profile(path, dx=DX) if kind == "profile" else read_surface(path, dx=DX))
    assert is_surface_file(path) is (kind == "surface")   # from its header alone


def test_a_long_tables_grid_beyond_the_limit_is_refused_before_it_is_allocated(tmp_path: Path,
                                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "table.csv"
    z = np.random.default_rng(0).normal(0.0, 1e-3, 200)
    rows = [f"{ix * 1e-3:.3f},{iy * 1e-3:.3f},{z[iy * 20 + ix]:.6f}" for iy in range(10) for ix in range(20)]
    path.write_text("x (m),y (m),z (m)\n" + "\n".join(rows) + "\n", encoding="utf-8")
    assert read_surface(path).shape == (10, 20)
    monkeypatch.setattr(limits, "MAX_POINTS", 100)
    with pytest.raises(ProfileFormatError, match=r"^table\.csv: its positions' grid of 10 x 20 nodes declares 200"):
        read_surface(path)


def test_the_manifest_commands_warning_names_the_file_whatever_the_error(tmp_path: Path,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    import roadtex.profiles.readers as readers
    from roadtex.cli import read_problem

    def reading(*args: object, **kwargs: object) -> None:
        raise MemoryError("Unable to allocate 14.9 GiB for an array with shape (20000, 100000)")

    monkeypatch.setattr(readers, "read_profile", reading)
    problem = read_problem(str(tmp_path / "sparse_big.npy"))
    assert problem is not None and problem.startswith("sparse_big.npy: MemoryError: Unable to allocate 14.9 GiB")
