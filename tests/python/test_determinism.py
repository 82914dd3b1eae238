"""Determinism: the same input gives the same bits, whatever the run, the process, the thread
count, or the other segments in the batch; and the bulk job writes identical tables with 1 or 2
threads.

"Bitwise" means equal bytes (``tobytes``), so -0.0 against 0.0 or two different NaNs would count
as a difference.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import polars as pl
import pytest
from polars.testing import assert_frame_equal

import roadtex
from roadtex.archive import ProcessingOptions, process
from roadtex.demo import write_synthetic_archive
from roadtex.errors import ImplausibleTextureWarning
from roadtex.profiles.pavements import synthetic_pavement
from roadtex.profiles.synthetic import self_affine_profile

DX = 5e-5
N = 2048
MODULI = [1e6, 2.5e6, 1e7]
P = 2e5
FIELDS = ("pressure", "envelope", "iterations", "residual", "converged")


def batch_segments() -> np.ndarray:
    """Eight segments that make the solver work differently: rough, a needle, flat, deep narrow
    pores, a staircase, porous asphalt, dense asphalt, and one in mm (the warning's case)."""
    rows = [self_affine_profile(N, N * DX, rms_slope=0.2, seed=s) for s in (1, 2)]
    rows[1][700] += 5e-3
    rows.append(np.zeros(N))
    pores = np.zeros(N)
    for s in range(40, N, 173):
        pores[s:s + 2] = -5e-3
    rows.append(pores)
    rows.append(np.floor(np.arange(N) / 128) * 2e-4)
    for kind in ("porous_asphalt", "dense_asphalt"):
        rows.append(np.asarray(synthetic_pavement(kind, N * DX, DX, seed=3).heights)[:N])
    rows.append(rows[-1] * 1000)
    return np.stack(rows)


@pytest.fixture(scope="module")
def segments() -> np.ndarray:
    return batch_segments()


def solve_many(segments: np.ndarray, threads: int | None, **kwargs) -> roadtex.ContactBatch:
    return roadtex.contact_many(segments, DX, MODULI, P, tol=1e-10, threads=threads, raise_on_nonconvergence=False,
                                **kwargs)


def digest(batch: roadtex.ContactBatch) -> str:
    """SHA-256 over every result array's bytes."""
    h = hashlib.sha256()
    for name in FIELDS:
        h.update(np.ascontiguousarray(getattr(batch, name)).tobytes())
    return h.hexdigest()


def assert_bitwise_equal(a: roadtex.ContactBatch, b: roadtex.ContactBatch) -> None:
    for name in FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.shape == y.shape and x.dtype == y.dtype, name
        assert x.tobytes() == y.tobytes(), f"{name} differs"


@pytest.fixture(scope="module")
def reference(segments) -> roadtex.ContactBatch:
    with pytest.warns(ImplausibleTextureWarning):
        return solve_many(segments, threads=1)


@pytest.mark.filterwarnings("ignore::roadtex.errors.ImplausibleTextureWarning")
@pytest.mark.parametrize("periodic", [True, False])
def test_contact_many_is_bitwise_identical_across_runs_and_thread_counts(segments, reference, periodic):
    """Three runs each with threads = 1, 2 and 4 (more threads than cores too) give the same
    bits, for the periodic and the finite model."""
    first = reference if periodic else solve_many(segments, threads=1, periodic=False)
    assert first.converged.all(), "every case of this batch converges"
    for threads in (1, 2, 4, 1, 2, 4, 2):
        assert_bitwise_equal(first, solve_many(segments, threads=threads, periodic=periodic))


@pytest.mark.filterwarnings("ignore::roadtex.errors.ImplausibleTextureWarning")
def test_result_does_not_depend_on_the_rest_of_the_batch(segments, reference):
    """A segment's result is the same bits whatever it is batched with, in any order, and equal
    to a one-by-one contact call."""
    order = np.random.default_rng(5).permutation(len(segments))
    shuffled = solve_many(segments[order], threads=2)
    for name in FIELDS:
        assert getattr(shuffled, name).tobytes() == getattr(reference, name)[order].tobytes(), name
    alone = solve_many(segments[3:4], threads=4)
    for name in FIELDS:
        assert getattr(alone, name).tobytes() == getattr(reference, name)[3:4].tobytes(), name
    for m, e in enumerate(MODULI):
        single = roadtex.contact(segments[5], DX, e, P, tol=1e-10)
        assert single.pressure.tobytes() == reference.pressure[5, m].tobytes()
        assert single.envelope.tobytes() == reference.envelope[5, m].tobytes()
        assert single.iterations == reference.iterations[5, m] and single.residual == reference.residual[5, m]


def test_contact_many_is_bitwise_identical_in_a_fresh_process(tmp_path: Path, segments, reference):
    """Another interpreter, with RAYON_NUM_THREADS=3 and the default thread count, gives the
    same SHA-256 over all result bytes."""
    np.save(tmp_path / "segments.npy", segments)
    script = (
        "import hashlib, warnings, numpy as np, roadtex\n"
        "warnings.simplefilter('ignore')\n"
        f"s = np.load({str(tmp_path / 'segments.npy')!r})\n"
        f"b = roadtex.contact_many(s, {DX!r}, {MODULI!r}, {P!r}, tol=1e-10, raise_on_nonconvergence=False)\n"
        "h = hashlib.sha256()\n"
        f"for name in {FIELDS!r}: h.update(np.ascontiguousarray(getattr(b, name)).tobytes())\n"
        "print(h.hexdigest())\n"
    )
    env = {**os.environ, "RAYON_NUM_THREADS": "3"}
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == digest(reference)


@pytest.mark.parametrize("method", ["cg", "direct"])
def test_contact_is_bitwise_repeatable(segments, method):
    """Repeated contact calls on one profile give the same bits (both methods)."""
    z = segments[0][:1024]
    runs = [roadtex.contact(z, DX, 2.5e6, P, tol=1e-12, method=method) for _ in range(3)]
    for r in runs[1:]:
        assert r.pressure.tobytes() == runs[0].pressure.tobytes()
        assert r.envelope.tobytes() == runs[0].envelope.tobytes()
        assert (r.iterations, r.residual) == (runs[0].iterations, runs[0].residual)


# --------------------------------------------------------------------------------------------
# the bulk job


OPTIONS = ProcessingOptions(youngs_moduli=(2e6, 1e7), segment_length=0.128, tol=1e-8)


def test_bulk_job_tables_are_identical_with_1_and_2_threads(tmp_path: Path):
    """roadtex.archive.process on the built-in synthetic archive (three pavements) writes the
    same combined and per-run tables, exactly, with threads=1, threads=2, again threads=2 and the
    job's own sharing of the cores between its runs in flight (threads=None)."""
    manifest = write_synthetic_archive(tmp_path / "archive", runs_per_kind=1, run_length=0.6, dx=5e-4)
    outs = []
    for k, threads in enumerate((1, 2, 2, None)):
        out = tmp_path / f"out{k}"
        summary = process(manifest, out, OPTIONS, quiet=True, threads=threads)
        assert summary.processed == 3 and summary.failed == 0
        outs.append(out)
    names = ["segments", "bands", "runs", "errors", "examples", "edge_effect", "von_meier", "penetration"]
    per_run = sorted(p.relative_to(outs[0]) for p in (outs[0] / "runs").glob("*/*.parquet"))
    # segments, bands, run, example, von_meier, penetration, sections, section_bands per run
    assert len(per_run) == 24
    for out in outs[1:]:
        for name in names:
            a, b = pl.read_parquet(outs[0] / f"{name}.parquet"), pl.read_parquet(out / f"{name}.parquet")
            assert_frame_equal(a, b, check_exact=True)
        for relative in per_run:
            assert_frame_equal(pl.read_parquet(outs[0] / relative), pl.read_parquet(out / relative), check_exact=True)
    # Not a vacuous comparison: the tables hold solved numbers.
    seg = pl.read_parquet(outs[0] / "segments.parquet")
    assert seg.height > 0 and seg["converged"].all() and (seg["contact_fraction"] > 0).all()
