"""Length units the readers and the command line understand, as factors to metres."""

from __future__ import annotations

from roadtex.errors import InvalidInputError

#: Factor to metres of every length unit a file header, a reader option or a manifest may name.
UNITS = {
    "m": 1.0, "metre": 1.0, "metres": 1.0, "meter": 1.0, "meters": 1.0,
    "mm": 1e-3, "millimetre": 1e-3, "millimetres": 1e-3, "millimeter": 1e-3, "millimeters": 1e-3,
    "cm": 1e-2, "km": 1e3,
    "um": 1e-6, "µm": 1e-6, "μm": 1e-6, "micron": 1e-6, "microns": 1e-6, "micrometre": 1e-6,
    "micrometer": 1e-6, "in": 0.0254, "inch": 0.0254, "inches": 0.0254, "ft": 0.3048,
}


def unit_factor(unit: str, what: str) -> float:
    """Factor to metres of ``unit`` (case and blanks ignored); ``what`` names it in the error."""
    key = unit.strip().lower()
    if key not in UNITS:
        raise InvalidInputError(f"unknown unit {unit!r} for {what}; known units: m, mm, cm, um (µm), km, in, ft")
    return UNITS[key]
