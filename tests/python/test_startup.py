"""Start-up (issue 39): ``roadtex --version`` and ``--help`` load neither the bulk job nor the
report (polars, scipy, matplotlib: about 1.6 s of imports), and ``import roadtex`` loads its public
names on first use, every one of them still there. Counted in modules loaded, never in seconds
(benches/startup.py times them)."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

#: What the two answers must not import: each costs 0.2 s or more (``python -X importtime``).
HEAVY = ("matplotlib", "polars", "scipy", "roadtex.report", "roadtex.archive", "roadtex.budget")


def loaded_after(code: str) -> dict:
    """Runs ``code`` in a fresh interpreter (this one's path); returns what it printed as JSON."""
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_version_and_help_import_neither_the_job_nor_the_report() -> None:
    for argv in (["--version"], ["--help"]):
        result = loaded_after(f"""
            import contextlib, io, json, sys
            import roadtex.cli
            with contextlib.redirect_stdout(io.StringIO()) as out:
                try:
                    roadtex.cli.main({argv!r})
                except SystemExit as stop:
                    code = stop.code
            print(json.dumps({{"modules": sorted(sys.modules), "code": code, "out": out.getvalue()}}))
        """)
        heavy = [m for m in result["modules"] if m.split(".")[0] in HEAVY or m.startswith(HEAVY)]
        assert heavy == [], f"roadtex {argv[0]} imported {heavy[:10]}"
        assert result["code"] == 0
        assert ("roadtex 0." in result["out"]) if argv == ["--version"] else ("process" in result["out"])


def test_import_roadtex_is_light_and_every_public_name_is_there() -> None:
    result = loaded_after("""
        import json, sys
        import roadtex
        light = sorted(sys.modules)
        missing = [name for name in roadtex.__all__ if getattr(roadtex, name, None) is None]
        from roadtex import contact, ProcessingOptions, build_report  # noqa: F401
        unlisted = sorted(set(roadtex.__all__) - set(dir(roadtex)))
        print(json.dumps({"light": light, "missing": missing, "unlisted": unlisted,
                          "plot": roadtex.plot.__name__, "contact": roadtex.contact.__module__}))
    """)
    heavy = [m for m in result["light"] if m.split(".")[0] in HEAVY or m.startswith(HEAVY)]
    assert heavy == [], f"import roadtex imported {heavy[:10]}"
    assert result["missing"] == [] and result["unlisted"] == []
    assert (result["plot"], result["contact"]) == ("roadtex.plot", "roadtex.models.contact")


def test_modules_reexported_by_subpackages_resolve_when_asked_for_first() -> None:
    # roadtex.reference is roadtex.models.reference, an attribute of roadtex.models only once
    # something imported it: asked for first (as tests/python/test_contact.py does), it must resolve
    result = loaded_after("""
        import json
        from roadtex import reference, synthetic, pavements
        print(json.dumps([m.__name__ for m in (reference, synthetic, pavements)]))
    """)
    assert result == ["roadtex.models.reference", "roadtex.profiles.synthetic", "roadtex.profiles.pavements"]


def test_process_options_are_there_when_process_is_parsed() -> None:
    # the process sub-command's options are added when it is first used: parsing, help, usage
    from roadtex.cli import build_parser

    args = build_parser().parse_args(["process", "m.csv", "--out", "o", "--moduli", "3", "--refine", "4"])
    assert (args.moduli, args.refine, args.pressure) == ([3.0], 4, 0.2)
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction").choices["process"]
    assert "--error-budget" in sub.format_help()
