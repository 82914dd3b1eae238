"""The README's ten-line example runs as written (the docs site runs its own examples when built;
the README is outside it)."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib

README = Path(__file__).resolve().parents[2] / "README.md"


def test_readme_first_profile_example_runs() -> None:
    matplotlib.use("Agg")
    section = README.read_text(encoding="utf-8").split("## A first profile", 1)[1]
    block = re.search(r"```python\n(.*?)```", section, re.S)
    assert block, "the README's first-profile section has no python block"
    names: dict[str, object] = {}
    exec(compile(block.group(1), "README.md: A first profile", "exec"), names)
    r = names["r"]
    assert r.converged and abs(r.pressure.mean() / 2e5 - 1) < 1e-9
    assert names["height_ax"].get_lines(), "the example's figure has the profile drawn"


def test_readme_stays_a_front_door() -> None:
    # The limit: about 200 lines; the manual lives in docs/.
    assert len(README.read_text(encoding="utf-8").splitlines()) <= 200
