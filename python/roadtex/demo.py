"""The built-in default data set and the main job on it (``roadtex demo``, ``scripts/demo.sh``)."""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path
from typing import Sequence

import numpy as np
import polars as pl

from roadtex._core import __version__
from roadtex.archive import ProcessingOptions, process
from roadtex.errors import ArchiveWriteError, ManifestError
from roadtex.profiles.pavements import synthetic_pavement
from roadtex.profiles.writer import write_profile
from roadtex.report import build_report
from roadtex.surfaces.synthetic import synthetic_surface

#: The seed's three pavements, the built-in demo archive.
DEMO_PAVEMENTS = ("cement_concrete", "dense_asphalt", "porous_asphalt")


def write_synthetic_archive(folder: str | os.PathLike[str], *, kinds: Sequence[str] = DEMO_PAVEMENTS,
                            runs_per_kind: int = 2, run_length: float = 4.0, dx: float = 5e-4,
                            file_format: str = "parquet", speed_kmh: float = 80.0, seed: int = 0,
                            surfaces_per_kind: int = 0, surface_size: tuple[float, float] = (0.5, 0.04),
                            surface_dx: float = 1e-3) -> Path:
    """Writes an archive of synthetic pavement runs (:func:`roadtex.pavements.synthetic_pavement`)
    as profile files plus ``manifest.csv``, as a survey would deliver it.

    Args:
        folder: where to write (created).
        kinds: pavement kinds, taken in turn.
        runs_per_kind: runs of each kind (each from its own seed).
        run_length: metres per run.
        dx: sampling interval (m).
        file_format: "parquet", "csv" or "npy".
        speed_kmh: the speed written into the manifest (km/h), for band frequencies.
        seed: seed of the first run; run i uses seed + i.
        surfaces_per_kind: 3D surface runs of each kind (:func:`roadtex.surfaces.synthetic_surface`),
            saved as 2-D ``.npy`` heights (m) with ``format`` "surface" and ``dx``, ``dy`` manifest columns.
        surface_size: (length along, width across) of each surface (m).
        surface_dx: the surfaces' spacing along and across (m).

    Returns:
        The manifest's path. An archive already written there with the same arguments is kept as
        it is (so a re-run finds its inputs unchanged); with other arguments it is rewritten.
    """
    root = Path(folder)
    root.mkdir(parents=True, exist_ok=True)
    suffix = {"parquet": ".parquet", "csv": ".csv", "npy": ".npy"}[file_format]
    recipe = {"kinds": list(kinds), "run_length": run_length, "dx": dx, "seed": seed, "format": file_format,
              "roadtex": __version__, "surfaces": [surfaces_per_kind, list(surface_size), surface_dx]}
    stamp = root / "archive.json"
    try:
        same = json.loads(stamp.read_text(encoding="utf-8")) == recipe
    except (OSError, ValueError):
        same = False
    rows = []
    for i in range(runs_per_kind * len(kinds)):
        kind = kinds[i % len(kinds)]
        run_id = f"{kind}_{i // len(kinds) + 1:03d}"
        path = root / f"{run_id}{suffix}"
        if not (same and path.exists()):
            write_profile(synthetic_pavement(kind, run_length, dx, seed=seed + i), path)
        rows.append({"path": path.name, "run_id": run_id, "site": f"synthetic-{run_id}", "pavement": kind,
                     "device": "roadtex synthetic pavement generator", "speed_kmh": speed_kmh})
    for i in range(surfaces_per_kind * len(kinds)):
        kind = kinds[i % len(kinds)]
        run_id = f"{kind}_surface_{i // len(kinds) + 1:03d}"
        path = root / f"{run_id}.npy"
        if not (same and path.exists()):
            surface = synthetic_surface(kind, surface_size[0], surface_size[1], surface_dx, seed=seed + 1000 + i)
            np.save(path, surface.heights)
        rows.append({"path": path.name, "run_id": run_id, "format": "surface", "dx": surface_dx, "dy": surface_dx,
                     "site": f"synthetic-{run_id}", "pavement": kind,
                     "device": "roadtex synthetic surface generator", "speed_kmh": speed_kmh})
    manifest = root / "manifest.csv"
    pl.DataFrame(rows, infer_schema_length=None).write_csv(manifest)
    stamp.write_text(json.dumps(recipe), encoding="utf-8")
    return manifest


def run_demo(out: Path, *, runs: int = 2, run_length: float = 4.0, moduli_mpa: Sequence[float] = (1, 2, 5, 10),
             pressure_mpa: float = 0.2, manifest_path: str | None = None, benchmark: str | None = None,
             quiet: bool = False) -> int:
    """The main job: the built-in archive (or ``manifest``) processed into ``out/results`` and the
    report drawn into ``out/report``. Moduli and pressure in MPa, as on the command line.

    Returns:
        The exit code: 0, 1 when some run failed, 2 when the job could not start.
    """
    started = time.perf_counter()
    if manifest_path is None:
        manifest = write_synthetic_archive(out / "archive", runs_per_kind=runs, run_length=run_length,
                                           surfaces_per_kind=1)
        print(f"roadtex demo: wrote a synthetic archive of cement concrete, dense asphalt and porous asphalt, "
              f"{runs} run(s) of {run_length:g} m each at 0.5 mm sampling and one 3D surface run of each "
              f"(0.5 m x 40 mm at 1 mm) -> {manifest}")
    else:
        manifest = Path(manifest_path)
        print(f"roadtex demo: processing the archive listed in {manifest}")
    options = ProcessingOptions(youngs_moduli=tuple(e * 1e6 for e in moduli_mpa), mean_pressure=pressure_mpa * 1e6)
    print(f"roadtex demo: roadtex process {manifest} --out {out / 'results'}: periodic INRETS contact of every "
          f"{options.segment_length:g} m segment at E = {', '.join(f'{e:g}' for e in moduli_mpa)} MPa, "
          f"P = {pressure_mpa:g} MPa; texture and pressure spectra; MPD")
    try:
        summary = process(manifest, out / "results", options, quiet=quiet)
    except (ManifestError, ArchiveWriteError, ValueError) as exc:
        print(f"roadtex demo: error: {exc}", file=sys.stderr)
        return 2
    print(f"roadtex demo: {summary}")
    report = build_report(out / "results", out_dir=out / "report", benchmark=benchmark)
    print(f"roadtex demo: report with {len(report.figures)} figures -> {report.html.resolve()}")
    print(f"roadtex demo: tables in {(out / 'results').resolve()} (segments.parquet, bands.parquet, runs.parquet, "
          f"errors.parquet); done in {time.perf_counter() - started:.1f} s")
    return 1 if summary.failed else 0
