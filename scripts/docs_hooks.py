"""MkDocs hooks: the pages generated from the code, so they can never disagree with it.

A page holds a marker comment and the hook replaces it at build time:

- ``<!-- roadtex:cli -->``: ``roadtex --help`` and each sub-command's ``--help``, from the argparse
  parser itself (:func:`roadtex.cli.build_parser`);
- ``<!-- roadtex:schemas -->``: every table the bulk job writes, column by column with its type, unit
  and the comment it carries in ``python/roadtex/archive/schemas.py``, and the manifest's columns;
- ``<!-- roadtex:api -->``: one mkdocstrings entry (``::: roadtex.NAME``) per name in
  ``roadtex.__all__``, grouped as the package groups them.

The build also runs with matplotlib's Agg back end (the executed examples draw figures) and fails
(``mkdocs build --strict``) on any broken link or reference.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import os
import re
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")
ROOT = Path(__file__).resolve().parents[1]
# The real CAPTIF files for the examples: shared/data/captif-slp beside the repository, looked up
# as tests/python/conftest.py does (ROADTEX_CAPTIF_DIR overrides); the examples fall back to
# synthetic profiles, and say so, where it is absent.
if "ROADTEX_CAPTIF_DIR" not in os.environ:
    for _folder in ROOT.parents:
        if (_folder / "shared" / "data" / "captif-slp").is_dir():
            os.environ["ROADTEX_CAPTIF_DIR"] = str(_folder / "shared" / "data" / "captif-slp")
            break


def cli_reference() -> str:
    import argparse

    from roadtex.cli import build_parser

    os.environ["COLUMNS"] = "100"  # argparse wraps its help to the terminal width: one width for the docs
    parser = build_parser()
    parts = ["## `roadtex`", "", "```text", parser.format_help().rstrip(), "```", ""]
    subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, sub in subparsers.choices.items():
        parts += [f"## `roadtex {name}`", "", "```text", sub.format_help().rstrip(), "```", ""]
    return "\n".join(parts)


def _column_comments(source: str, table: str) -> dict[str, str]:
    """The trailing comment of each column line in the declaration ``table: Columns = {...}``."""
    block = re.search(rf"^{table}\b[^\n]*= \{{\n(.*?)^\}}", source, re.S | re.M)
    if block is None:
        return {}
    comments = {}
    for line in block.group(1).splitlines():
        match = re.match(r'\s*"(\w+)":[^#]*(?:#\s*(.*))?$', line)
        if match:
            comments[match.group(1)] = (match.group(2) or "").strip()
    return comments


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def schema_reference() -> str:
    import polars as pl

    from roadtex.archive import schemas

    source = (ROOT / "python" / "roadtex" / "archive" / "schemas.py").read_text(encoding="utf-8")
    declared = {value_name: name for name in dir(schemas) if name.endswith("_COLUMNS")
                for value_name in [name] if isinstance(getattr(schemas, name), dict)}
    parts = ["## The manifest", "",
             "`path` is the only required column. Run metadata (copied into every segment row):", "",
             "| column | type |", "|---|---|"]
    parts += [f"| `{name}` | {dtype if isinstance(dtype, pl.DataType) else dtype()} |"
              for name, dtype in schemas.MANIFEST_COLUMNS.items()]
    parts += ["", "Reader options per run (override the command line's reader defaults for that run):", "",
              "| column | type |", "|---|---|"]
    parts += [f"| `{name}` | {dtype()} |" for name, dtype in schemas.READER_COLUMNS.items()]
    parts += ["", f"Measured noise levels: `{schemas.NOISE_PREFIX}<centre frequency in Hz>` (dB), carried for "
              "`roadtex.calibrate_modulus`, unused by the job.", ""]
    for stem, columns in schemas.TABLES.items():
        table_name = next((n for n in declared if getattr(schemas, n) is columns), None)
        comments = _column_comments(source, table_name) if table_name else {}
        parts += [f"## `{stem}.parquet`", "", "| column | type | unit | what |", "|---|---|---|---|"]
        for name, (dtype, unit) in columns.items():
            parts.append(f"| `{name}` | {dtype} | {unit or ''} | {_cell(comments.get(name, ''))} |")
        parts.append("")
    return "\n".join(parts)


API_GROUPS = (
    ("Contact models", ("contact", "contact_many", "ContactResult", "ContactBatch", "contact_surface",
                        "contact_surface_many", "SurfaceResult", "SurfaceBatch", "von_meier", "clapp", "ClappResult")),
    ("Profiles: reading, conditioning, MPD", ("read_profile", "write_profile", "Profile", "Segments", "mpd",
                                              "MpdResult", "synthetic_pavement")),
    ("3D surfaces", ("read_surface", "Surface", "synthetic_surface", "sett_surface")),
    ("Spectra", ("band_levels", "third_octave_levels", "octave_levels", "pressure_levels", "BandLevels",
                 "band_table", "level_differences", "band_regressions", "time_frequency", "with_time_frequency",
                 "calibrate_modulus", "CalibrationResult")),
    ("The error budget", ("choose_setting", "BudgetChoice", "convergence_study")),
    ("The bulk job and the report", ("process", "ProcessingOptions", "build_manifest", "read_manifest",
                                     "read_profiles", "build_report", "JobInterrupted")),
    ("Plotting", ()),
    ("Modules", ("comparisons", "reference", "pavements", "synthetic", "errors")),
)


def api_reference() -> str:
    import roadtex

    exported = [n for n in roadtex.__all__ if n != "__version__"]
    errors = [n for n in exported if n.endswith(("Error", "Warning", "Failure"))]
    grouped = {n for _, names in API_GROUPS for n in names} | set(errors)
    missing = [n for n in exported if n not in grouped]
    unknown = [n for n in grouped if n not in roadtex.__all__]
    if missing or unknown:  # a new public name must get a place here (the strict build stops)
        raise RuntimeError(f"docs API groups out of date: not placed {missing}, not exported {unknown}")
    parts = [f"`roadtex.__version__` is the installed version (`{roadtex.__version__}` when these pages were built).", ""]
    options = "    options:\n      show_root_heading: true\n      heading_level: 3"
    for title, names in API_GROUPS:
        if title == "Plotting":
            if importlib.util.find_spec("roadtex.plot") is None:
                continue
            parts += ["## Plotting", "", "::: roadtex.plot", "    options:\n      show_root_heading: true\n"
                      "      heading_level: 3\n      members_order: source", ""]
            continue
        parts += [f"## {title}", ""]
        for name in names:
            parts += [f"::: roadtex.{name}", options, ""]
    parts += ["## Errors and warnings", "", "Every error is a `roadtex.errors.RoadtexError`, every warning a "
              "`roadtex.errors.RoadtexWarning`.", ""]
    for name in errors:
        parts += [f"::: roadtex.{name}", options, ""]
    return "\n".join(parts)


GENERATORS = {"cli": cli_reference, "schemas": schema_reference, "api": api_reference}


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ARG001 (the hook's signature)
    def replace(match: re.Match[str]) -> str:
        with contextlib.redirect_stdout(io.StringIO()):
            return GENERATORS[match.group(1)]()

    return re.sub(r"<!-- roadtex:(\w+) -->", replace, markdown)


#: Sphinx roles in the docstrings (:func:`x`), rendered by mkdocstrings as the role's text before the
#: code: the code alone reads as intended ("~" keeps only the last dotted name, as in Sphinx).
SPHINX_ROLE = re.compile(r":(?:func|class|meth|data|mod|attr|exc):<code>(~)?([^<]*)</code>")


def _code(match: re.Match[str]) -> str:
    name = match.group(2).rsplit(".", 1)[-1] if match.group(1) else match.group(2)
    return f"<code>{name}</code>"


def on_page_content(html: str, page, config, files) -> str:  # noqa: ARG001 (the hook's signature)
    """An executed example that raised fails the build: markdown-exec renders the traceback into the
    page and only logs it, which would let an example rot in a green build."""
    html = SPHINX_ROLE.sub(_code, html)
    import html as entities

    text = entities.unescape(re.sub(r"<[^>]+>", "", html))  # highlighted: tags inside the traceback
    start = text.find("Traceback (most recent call last)")
    if start >= 0:
        from mkdocs.exceptions import PluginError

        raise PluginError(f"an executed code block failed on {page.file.src_path}:\n{text[start:start + 3000]}")
    return html
