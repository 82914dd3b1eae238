"""The house rules of issue 13, checked: one error hierarchy, panics never escape as
PanicException and never stop a bulk job, the report reads only the job's outputs, imports flow
one way."""

from __future__ import annotations

import ast
import shutil
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex import _core, errors
from roadtex.archive import ProcessingOptions, process
from roadtex.demo import write_synthetic_archive

PACKAGE = Path(roadtex.__file__).parent
OPTIONS = ProcessingOptions(youngs_moduli=(1e6, 5e6), segment_length=0.25, tol=1e-6)


def test_every_error_and_warning_class_is_under_the_two_roots() -> None:
    for name in errors.__all__:
        cls = getattr(errors, name)
        root = errors.RoadtexWarning if issubclass(cls, Warning) else errors.RoadtexError
        if issubclass(cls, KeyboardInterrupt):
            # Ctrl-C stays a KeyboardInterrupt (JobInterrupted): under RoadtexError, an Exception,
            # any 'except Exception' would swallow it
            root = KeyboardInterrupt
        assert issubclass(cls, root), f"{name} is not under {root.__name__}"


def test_every_error_and_warning_class_is_exported_from_the_package_root() -> None:
    """What the functions document they raise or warn must be reachable as roadtex.<Name>."""
    missing = [name for name in errors.__all__ if name not in roadtex.__all__ or getattr(roadtex, name) is not getattr(errors, name)]
    assert missing == []


def test_no_module_defines_an_exception_outside_errors_py() -> None:
    offenders = []
    for path in PACKAGE.rglob("*.py"):
        if path.name == "errors.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef) and any(
                    isinstance(base, ast.Name) and base.id.endswith(("Error", "Exception", "Warning"))
                    for base in node.bases):
                offenders.append(f"{path.relative_to(PACKAGE)}:{node.name}")
    assert offenders == []


def test_bad_input_is_an_invalid_input_error_and_still_a_value_error() -> None:
    with pytest.raises(errors.InvalidInputError) as caught:
        roadtex.contact(np.zeros(16), dx=-1.0, youngs_modulus=1e6, mean_pressure=2e5)
    assert isinstance(caught.value, ValueError)
    assert "dx" in str(caught.value)


def test_a_panic_in_the_core_reaches_python_as_internal_error() -> None:
    with pytest.raises(errors.InternalError, match="deliberate test panic 42"):
        _core._panic_for_tests("deliberate test panic 42")


def test_clapp_refuses_a_sub_profile_above_the_dense_cap() -> None:
    z = 1e-4 * np.sin(np.linspace(0, 40 * np.pi, 40_000))
    with pytest.raises(ValueError, match="sub_profile"):
        roadtex.clapp(z, 1e-5, 2.5e6, 2e5, sub_profile=20_000, overlap=256)


def test_no_module_imports_a_name_from_the_package_root() -> None:
    offenders = []
    for path in PACKAGE.rglob("*.py"):
        if path == PACKAGE / "__init__.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module == "roadtex":
                names = [alias.name for alias in node.names if alias.name != "_core"]
                if names:
                    offenders.append(f"{path.relative_to(PACKAGE)} imports {names} from roadtex")
    assert offenders == []


# Lower layers never import higher ones: the order in which data flows.
LAYERS = ["errors", "_checks", "profiles", "surfaces", "models", "spectra", "comparisons", "budget", "plot", "archive",
          "report", "demo", "cli"]


def _layer(module: str) -> int | None:
    parts = module.split(".")
    if parts[0] != "roadtex" or len(parts) < 2 or parts[1] == "_core":
        return None
    return LAYERS.index(parts[1]) if parts[1] in LAYERS else None


def test_imports_flow_one_way_between_subpackages() -> None:
    offenders = []
    for path in PACKAGE.rglob("*.py"):
        module = "roadtex." + ".".join(path.relative_to(PACKAGE).with_suffix("").parts)
        own = _layer(module)
        if own is None:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("roadtex."):
                other = _layer(node.module)
                if other is not None and other > own:
                    offenders.append(f"{module} imports {node.module}")
    assert offenders == []


def test_no_source_file_is_over_600_lines() -> None:
    root = PACKAGE.parents[1]
    sources = [*PACKAGE.rglob("*.py"), *(root / "src").rglob("*.rs"), *(root / "tests").rglob("*.rs"),
               *(root / "tests" / "python").glob("*.py"), *(root / "benches").glob("*")]
    long = {str(p.relative_to(root)): n for p in sources if p.is_file()
            and (n := len(p.read_text(encoding="utf-8").splitlines())) > 600}
    assert long == {}


def test_a_panic_in_any_extension_module_is_that_runs_failure(tmp_path: Path, monkeypatch) -> None:
    """A PanicException (a BaseException, as polars and every pyo3 module raise it) in one run is
    recorded as that run's error; the job goes on and the other runs are complete."""
    manifest = write_synthetic_archive(tmp_path / "archive", runs_per_kind=1, run_length=0.6)
    from roadtex.archive import compute

    real_read = compute.read_profile

    def panicking_read(path, **kwargs):
        if "dense_asphalt" in str(path):
            raise pl.exceptions.PanicException("a library panicked on this file")
        if "porous_asphalt" in str(path):
            _core._panic_for_tests("the core panicked on this file")
        return real_read(path, **kwargs)

    monkeypatch.setattr(compute, "read_profile", panicking_read)
    summary = process(manifest, tmp_path / "out", OPTIONS, quiet=True)
    assert (summary.processed, summary.failed) == (1, 2)
    failures = pl.read_parquet(tmp_path / "out" / "errors.parquet").sort("run_id")
    assert failures["run_id"].to_list() == ["dense_asphalt_001", "porous_asphalt_001"]
    assert failures["error_type"].to_list() == ["PanicException", "InternalError"]
    assert failures["stage"].to_list() == ["read", "read"]
    segments = pl.read_parquet(tmp_path / "out" / "segments.parquet")
    assert segments["run_id"].unique().to_list() == ["cement_concrete_001"]


def test_the_report_builds_from_the_results_folder_alone(tmp_path: Path) -> None:
    """The inputs are deleted after processing: the report still builds, and its example data is
    the job's own solve (the example segment's contact fraction is the one in segments.parquet)."""
    manifest = write_synthetic_archive(tmp_path / "archive", runs_per_kind=1, run_length=0.6)
    results = tmp_path / "results"
    process(manifest, results, OPTIONS, quiet=True)
    shutil.rmtree(tmp_path / "archive")
    report = roadtex.build_report(results)
    assert report.html.exists() and len(report.figures) >= 8
    examples = pl.read_parquet(results / "examples.parquet")
    segments = pl.read_parquet(results / "segments.parquet")
    assert examples["run_id"].n_unique() == 3
    for (run_id, segment, modulus), rows in examples.group_by("run_id", "segment", "youngs_modulus"):
        pressure = rows["pressure"].to_numpy()
        assert abs(pressure.mean() / OPTIONS.mean_pressure - 1) < 1e-9
        assert np.all(rows["envelope"].to_numpy() >= rows["height"].to_numpy() - 1e-12)
        expected = segments.filter((pl.col("run_id") == run_id) & (pl.col("segment") == segment)
                                   & (pl.col("youngs_modulus") == modulus))["contact_fraction"].item()
        assert np.mean(pressure > 0) == expected


def test_the_report_builds_when_the_manifest_names_no_pavement(tmp_path: Path) -> None:
    """A manifest made from a folder has no pavement column: runs are then grouped by run id
    (this crashed with a polars DuplicateError on run_id)."""
    manifest = write_synthetic_archive(tmp_path / "archive", runs_per_kind=1, run_length=0.6)
    table = pl.read_csv(manifest).drop("pavement")
    table.write_csv(manifest)
    results = tmp_path / "results"
    process(manifest, results, OPTIONS, quiet=True)
    report = roadtex.build_report(results)
    text = report.html.read_text(encoding="utf-8")
    for run_id in table["run_id"]:
        assert run_id in text
