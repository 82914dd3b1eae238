"""A real CAPTIF profile re-exported the way colleagues send profiles, with the faults they carry.

Used by the user-path tests: each file is the same road as the clean CAPTIF file, so results that
should not depend on the export (MPD, the trimmed length) can be compared with the clean file's.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np

#: position (m) of the single +30 mm spike, and where the 20-reading -850 mm drop-out code starts
SPIKE_AT = 0.75
DROPOUT_AT = 1.2


def _captif_rows(text: str) -> tuple[list[str], list[str]]:
    """(header lines up to and including the column names, data lines) of a CAPTIF text file."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("Data Point No")) + 1
    return lines[:start], lines[start:]


def _with_height(rows: list[str], index: int, height_mm: float) -> None:
    point, distance, _ = rows[index].split("\t")[:3]
    rows[index] = f"{point}\t{distance}\t{height_mm:.3f}"


def write_colleague_exports(clean: Path, folder: Path) -> dict[str, dict[str, object]]:
    """Writes the exports of ``clean`` (a CAPTIF .dat) into ``folder``.

    Returns:
        file name -> manifest reader columns a user has to add for it (units the file does not
        state, a heights-only file's sampling interval). A file whose value is ``{"refused": ...}``
        carries no such help (or a wrong one) and must be refused with that text in its reason.
    """
    folder.mkdir(parents=True, exist_ok=True)
    text = clean.read_text(encoding="utf-8")
    header, rows = _captif_rows(text)
    table = np.array([[float(v) for v in row.split("\t")[1:3]] for row in rows if row.strip()])
    distance_mm, height_mm = table[:, 0], table[:, 1]
    exports: dict[str, dict[str, object]] = {}

    shutil.copy(clean, folder / "clean.dat")
    exports["clean.dat"] = {}

    spiked = list(rows)
    at = int(np.searchsorted(distance_mm, SPIKE_AT * 1e3))
    _with_height(spiked, at, height_mm[at] + 30.0)
    (folder / "spike.dat").write_text("\n".join(header + spiked) + "\n", encoding="utf-8")
    exports["spike.dat"] = {}

    dropped = list(rows)
    first = int(np.searchsorted(distance_mm, DROPOUT_AT * 1e3))
    for i in range(first, first + 20):
        _with_height(dropped, i, -850.0)
    (folder / "deep_dropout.dat").write_text("\n".join(header + dropped) + "\n", encoding="utf-8")
    exports["deep_dropout.dat"] = {}

    finite = ~np.isnan(height_mm)
    # drop-outs as empty fields, as spreadsheets write them
    cells = [(f"{d:.3f}", f"{h:.3f}" if ok else "") for d, h, ok in zip(distance_mm, height_mm, finite)]
    (folder / "headerless.tsv").write_text("".join(f"{d}\t{h}\n" for d, h in cells), encoding="utf-8")
    exports["headerless.tsv"] = {"distance_unit": "mm", "height_unit": "mm"}
    shutil.copy(folder / "headerless.tsv", folder / "no_units_given.tsv")
    exports["no_units_given.tsv"] = {"refused": "height_unit"}

    european = "Distance (mm);Height (mm)\n" + "".join(
        f"{d.replace('.', ',')};{h.replace('.', ',')}\n" for d, h in cells)
    (folder / "european.csv").write_text(european, encoding="latin-1")
    exports["european.csv"] = {}

    (folder / "xz.csv").write_text("x,z\n" + "".join(f"{d},{h}\n" for d, h in cells), encoding="utf-8")
    exports["xz.csv"] = {"distance_unit": "mm", "height_unit": "mm"}

    # a survey tool's export: a metadata block without comment marks before the header, Windows
    # line ends, a UTF-8 byte-order mark, decimal commas
    table_eu = "".join(f"{d.replace('.', ',')};{h.replace('.', ',')}\n" for d, h in cells)
    block = "Site: CAPTIF\nOperator: A. Colleague\nDate: 2021-10-11\n\nDistance (mm);Height (mm)\n"
    (folder / "metadata_block.csv").write_bytes(("\ufeff" + block + table_eu).replace("\n", "\r\n").encode("utf-8"))
    exports["metadata_block.csv"] = {}

    # Excel's "Save as CSV" in a European locale: a sep= line, quoted names, blank and ";" lines at the end
    excel = 'sep=;\n"Distance (mm)";"Height (mm)"\n' + table_eu + ";\n;\n\n"
    (folder / "excel.csv").write_bytes(excel.replace("\n", "\r\n").encode("utf-8"))
    exports["excel.csv"] = {}

    # the headerless file again, but the colleague says micrometres for heights written in mm:
    # 1000 times too small, which must be refused rather than solved
    shutil.copy(folder / "headerless.tsv", folder / "mm_said_um.tsv")
    exports["mm_said_um.tsv"] = {"distance_unit": "mm", "height_unit": "um", "refused": "implausibly small"}

    # heights only, in metres, on the file's nominal grid (a colleague's numpy dump)
    spacing_m = float((distance_mm[-1] - distance_mm[0]) / (distance_mm.size - 1)) * 1e-3
    np.save(folder / "heights_only.npy", height_mm * 1e-3)
    exports["heights_only.npy"] = {"dx": spacing_m}
    return exports


def readme_bulk_commands(readme: Path) -> list[list[str]]:
    """The ``roadtex ...`` command lines of the README's bulk-job block, comments stripped, as argv lists."""
    text = readme.read_text(encoding="utf-8")
    section = text.split("## The bulk job", 1)[1]
    block = re.search(r"```bash\n(.*?)```", section, re.S)
    assert block, "the README's bulk-job section has no bash block"
    commands = []
    for line in block.group(1).splitlines():
        command = line.split("#", 1)[0].strip()
        if command.startswith("roadtex "):
            commands.append(command.split())
    return commands
