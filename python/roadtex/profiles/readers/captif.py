"""The CAPTIF stationary laser profilometer's text format."""

from __future__ import annotations

import re

import numpy as np

from roadtex.errors import ProfileFormatError
from roadtex.profiles.plausibility import set_distance_unit
from roadtex.profiles.readers.screening import dropout_codes
from roadtex.profiles.readers.text import ReadResult, column_unit, first_lines, parse_table, parse_value, stated_unit

#: The line that ends a CAPTIF file's metadata block.
CAPTIF_MARKER = b"*****DATA*****"


def read_captif(data: bytes, name: str, options: dict) -> ReadResult:
    lines, ends = first_lines(data, 64)
    marker = next((i for i, line in enumerate(lines) if line.strip().startswith(CAPTIF_MARKER)), None)
    if marker is None:
        raise ProfileFormatError(f"{name}: not a CAPTIF profile file (no '*****DATA*****' line in its first 64 lines)")
    metadata: dict[str, object] = {}
    for line in lines[:marker]:
        parts = [p.strip() for p in line.decode("utf-8", "replace").split("\t")]
        key = parts[0]
        values = [p for p in parts[1:] if p]
        if not key:
            continue
        metadata[re.sub(r"\W+", "_", key.strip().lower()).strip("_")] = " ".join(values)
    if marker + 1 >= len(lines):
        raise ProfileFormatError(f"{name}: CAPTIF file ends after its '*****DATA*****' line (no header, no data)")
    header = [h.strip() for h in lines[marker + 1].decode("utf-8", "replace").split("\t") if h.strip()]
    if len(header) < 3:
        raise ProfileFormatError(f"{name}: CAPTIF header line should name 3 columns (point, distance, height), got {header}")
    # the header's units (mm), else the units given, else mm; a given unit never rescales a stated one
    distance_factor = column_unit(header, 1, options.get("distance_unit"), "distance", source=name, default="mm")
    height_factor = column_unit(header, 2, options.get("height_unit"), "height", source=name, default="mm")
    body = data[ends[marker + 1]:]
    if not body or body.isspace():
        raise ProfileFormatError(f"{name}: CAPTIF file has a header but no data rows")
    if not body.endswith(b"\n"):
        # The profilometer ends every row with a line end: without one, the file was cut, and
        # possibly inside a number (3.144 read as 3.1), which no per-value check can see.
        raise ProfileFormatError(f"{name}: CAPTIF file ends inside a data row (no line end after its last row): "
                         "the file is truncated")
    table, absent = parse_table(body, "\t", 3, name, marker + 2)
    missing = np.flatnonzero(absent.any(axis=1) | np.isnan(table[:, 1]))
    if missing.size:
        row = int(missing[0])
        raise ProfileFormatError(f"{name}: data row {row + 1} (line {marker + 3 + row}) has a missing value "
                         "(truncated or malformed file); drop-outs are written NaN")
    # The file calls it "Depth", but it is a height, positive up (CAPTIF's README).
    positions = table[:, 1] * distance_factor
    raw_heights, codes_note = dropout_codes(table[:, 2], options.get("dropout_value"))
    heights = raw_heights * height_factor
    normalised: dict[str, object] = {
        "format": "captif", "device": "CAPTIF stationary laser profilometer",
    }
    renames = {"road_name": "site", "ref_station": "ref_station", "start_pos_m": "start_position_m",
               "end_pos_m": "end_position_m", "direction": "direction", "wheel_path": "wheel_path",
               "file_no": "file_number", "current_pos": "current_position_m", "date": "date"}
    for key, value in metadata.items():
        target = renames.get(key, key)
        if target == "date":
            match = re.match(r"^(\d{1,2})/(\d{1,2})/(\d{4})(.*)$", str(value))
            if match:
                day, month, year, rest = match.groups()
                normalised["date"] = f"{int(year):04d}-{int(month):02d}-{int(day):02d}"
                if rest.strip():
                    normalised["time"] = rest.strip()
                continue
        normalised[target] = parse_value(str(value)) if value != "" else None
    # the format's distances are in mm (a header without its unit included): certain, never assumed
    set_distance_unit(normalised, stated_unit(header, 1, options.get("distance_unit"), "mm (the CAPTIF format)"))
    return positions, heights, normalised, [codes_note] if codes_note else [], options.get("dx")
