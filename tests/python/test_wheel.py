"""The built wheel, installed as a user without a compiler installs it: a fresh virtual environment,
no Rust toolchain on PATH, the library and the ``roadtex`` command run on a real CAPTIF file.

Opt-in: set ``ROADTEX_WHEEL_TEST=1`` (the release workflow does, after ``maturin build``). It uses
``ROADTEX_WHEEL`` (a path) or else the newest ``dist/roadtex-*-abi3-*.whl`` (``maturin build
--release --out dist``), and fails when there is none. Why not whenever a wheel is present: a wheel
left in ``dist/`` from an older build would be tested in place of the code under test, and
installing the dependencies (numpy, scipy, polars, matplotlib) into a fresh environment takes a
minute or more from the package index: the normal suite (``scripts/test.sh``) must not pay that on
every run, and it builds no wheel.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(os.environ.get("ROADTEX_WHEEL_TEST") != "1",
                                reason="installs the built wheel into a fresh venv (a minute or more): set ROADTEX_WHEEL_TEST=1")


def built_wheel() -> Path:
    given = os.environ.get("ROADTEX_WHEEL")
    if given:
        assert Path(given).is_file(), f"ROADTEX_WHEEL={given} is not a file"
        return Path(given)
    wheels = sorted((ROOT / "dist").glob("roadtex-*.whl"), key=lambda p: p.stat().st_mtime)
    assert wheels, f"no wheel in {ROOT / 'dist'}: run `maturin build --release --out dist` first (or set ROADTEX_WHEEL)"
    return wheels[-1]


def without_rust(path: str) -> str:
    """PATH less every folder holding cargo, rustc or rustup (~/.cargo/bin and any other)."""
    tools = ("cargo", "rustc", "rustup")
    kept = [d for d in path.split(os.pathsep) if d and not any(shutil.which(t, path=d) for t in tools)]
    return os.pathsep.join(kept)


def test_wheel_is_abi3() -> None:
    # One wheel per platform for every Python >= 3.11: the tag says so (cp311-abi3).
    name = built_wheel().name
    assert "-cp311-abi3-" in name, name


def test_wheel_installs_and_runs_without_rust(tmp_path: Path, captif_dir: Path) -> None:
    wheel = built_wheel()
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    bin_dir = venv / ("Scripts" if os.name == "nt" else "bin")
    python = bin_dir / ("python.exe" if os.name == "nt" else "python")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "CARGO_HOME", "RUSTUP_HOME")}
    env["PATH"] = os.pathsep.join([str(bin_dir), without_rust(os.environ.get("PATH", ""))])
    # The environment really has no Rust toolchain: neither on PATH nor reachable through rustup.
    assert shutil.which("cargo", path=env["PATH"]) is None
    assert shutil.which("rustc", path=env["PATH"]) is None
    env["CARGO_HOME"] = env["RUSTUP_HOME"] = str(tmp_path / "no-rust")

    def run(*args: str) -> subprocess.CompletedProcess[str]:
        done = subprocess.run(list(args), cwd=tmp_path, env=env, capture_output=True, text=True)
        assert done.returncode == 0, f"{args} exited {done.returncode}:\n{done.stdout}\n{done.stderr}"
        return done

    # --only-binary: a wheel, never a source build of roadtex or of a dependency.
    run(str(python), "-m", "pip", "install", "--quiet", "--only-binary", ":all:", str(wheel))
    with pytest.raises(FileNotFoundError):
        subprocess.run(["cargo", "--version"], env=env, capture_output=True)

    captif = sorted(captif_dir.glob("*.dat"))[0]
    library = textwrap.dedent(f"""
        import pathlib, numpy as np, roadtex
        # the installed package, not the work tree's python/ folder
        assert pathlib.Path(roadtex.__file__).resolve().is_relative_to(pathlib.Path({str(venv)!r}).resolve()), roadtex.__file__
        z = 1e-4 * np.cos(2 * np.pi * np.arange(1024) / 1024)
        r = roadtex.contact(z, dx=1e-5, youngs_modulus=2.5e6, mean_pressure=2e5)
        assert r.converged and abs(r.pressure.mean() / 2e5 - 1) < 1e-9 and (r.pressure >= 0).all()
        p = roadtex.read_profile({str(captif)!r})
        assert abs(p.dx - 3.75e-5) < 1e-6 and p.heights.size > 40_000, (p.dx, p.heights.size)
        m = roadtex.mpd(p)
        assert m.is_valid and 2e-3 < m.mpd < 5e-3, m.mpd   # CAPTIF chip seals: about 3 to 3.5 mm
        import matplotlib
        matplotlib.use("Agg")
        import roadtex.plot
        fig, (top, bottom) = roadtex.plot.profile(z, 1e-5, envelope=r.envelope, pressure=r.pressure)
        fig.savefig("profile.png")
        print(roadtex.__version__, p.heights.size, m.mpd)
    """)
    version = run(str(python), "-c", library).stdout.split()[0]
    assert (tmp_path / "profile.png").stat().st_size > 10_000, "roadtex.plot drew nothing from the wheel"
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["version"]
    assert version == project, f"the wheel is roadtex {version}, the work tree {project}: a stale wheel?"

    manifest = tmp_path / "manifest.csv"
    manifest.write_text(f"path,run_id\n{captif.as_posix()},captif\n", encoding="utf-8")
    roadtex_cmd = bin_dir / ("roadtex.exe" if os.name == "nt" else "roadtex")
    run(str(roadtex_cmd), "process", str(manifest), "--out", str(tmp_path / "results"), "--moduli", "2",
        "--error-budget", "off", "--quiet")
    check = textwrap.dedent(f"""
        import polars as pl
        runs = pl.read_parquet({str(tmp_path / 'results' / 'runs.parquet')!r})
        bands = pl.read_parquet({str(tmp_path / 'results' / 'bands.parquet')!r})
        assert runs["run_id"].to_list() == ["captif"], runs
        assert runs["mpd"][0] > 2e-3 and bands.filter(pl.col("reported")).height > 0
        print("ok")
    """)
    assert run(str(python), "-c", check).stdout.strip() == "ok"
