"""Shared fixtures: the real CAPTIF profiles from ../shared (never copied into the repository)."""

from __future__ import annotations

from pathlib import Path

import pytest

#: ../shared/data/captif-slp beside the repository (see the brief: real data lives outside the repo).
CAPTIF_DIR = Path(__file__).resolve().parents[3] / "shared" / "data" / "captif-slp"


@pytest.fixture(scope="session")
def captif_dir() -> Path:
    """The folder of the three CAPTIF laser-profilometer files; skips when ../shared is absent."""
    if not CAPTIF_DIR.is_dir() or not list(CAPTIF_DIR.glob("*.dat")):
        pytest.skip(f"real CAPTIF profiles not found at {CAPTIF_DIR} (the ../shared folder beside the repo)")
    return CAPTIF_DIR
