"""Argument checks shared by the public functions: one place, so that the same mistake gets the
same message whichever function it is made in. Each raises InvalidInputError (a ValueError)
naming the argument."""

from __future__ import annotations

import math
import warnings

import numpy as np

from roadtex.errors import ImplausibleParameterWarning, InvalidInputError

#: Plausible rubber Young's moduli (Pa): tyre tread compounds are 1 to 10 MPa; this leaves a
#: decade either side. Outside it, a modulus is taken for a unit mistake (MPa given as Pa, ...).
PLAUSIBLE_MODULUS = (1e5, 1e8)
#: Plausible mean contact pressures (Pa): car tyres are inflated to about 0.2 MPa, trucks to about
#: 0.9 MPa; this leaves room either side.
PLAUSIBLE_PRESSURE = (2e4, 3e6)
#: The solvers, which also take model problems (Westergaard at a few kPa, a gel, a stiff wheel),
#: warn only outside these wider ranges (Pa), where no rubber-on-road problem lies: a modulus or
#: pressure in MPa given as Pa (E = 2.5, P = 0.2) or in Pa given as MPa.
SOLVER_PLAUSIBLE_MODULUS = (1e4, 1e10)
SOLVER_PLAUSIBLE_PRESSURE = (1e2, 1e8)


def implausible_parameter(value: float, name: str, plausible: tuple[float, float]) -> str | None:
    """Why ``value`` (Pa) is implausible for ``name``, or None."""
    low, high = plausible
    if low <= value <= high:
        return None
    return (f"{name} = {value:.4g} Pa is outside the plausible range {low / 1e6:g} to {high / 1e6:g} MPa "
            f"({value / 1e6:.4g} MPa): is it in the wrong unit?")


def warn_if_implausible_parameter(value: float, name: str, plausible: tuple[float, float], *,
                                  stacklevel: int = 4) -> None:
    """Warns (:class:`ImplausibleParameterWarning`) when ``value`` (Pa) is outside ``plausible``.
    Values the solvers refuse anyway (not positive, not finite) are left to their error."""
    if not (math.isfinite(value) and value > 0):
        return
    reason = implausible_parameter(value, name, plausible)
    if reason is not None:
        warnings.warn(reason + " Computing as given (for a dimensionless model problem, silence "
                      "roadtex.ImplausibleParameterWarning).", ImplausibleParameterWarning, stacklevel=stacklevel)


def warn_if_implausible_rubber(youngs_moduli: object, mean_pressure: float) -> None:
    """The solvers' unit check on their rubber and load: warns once for the first modulus (Pa)
    and for the mean pressure (Pa) outside :data:`SOLVER_PLAUSIBLE_MODULUS` /
    :data:`SOLVER_PLAUSIBLE_PRESSURE`, pointing at the caller of the public function that called
    this."""
    try:
        moduli = np.atleast_1d(np.asarray(youngs_moduli, dtype=np.float64)).ravel()
    except (TypeError, ValueError):
        return  # the argument checks name it
    odd = [e for e in moduli if implausible_parameter(e, "youngs_modulus", SOLVER_PLAUSIBLE_MODULUS) is not None
           and math.isfinite(e) and e > 0]
    if odd:
        warn_if_implausible_parameter(float(odd[0]), "youngs_modulus", SOLVER_PLAUSIBLE_MODULUS)
    warn_if_implausible_parameter(float(mean_pressure), "mean_pressure", SOLVER_PLAUSIBLE_PRESSURE)


def as_float_array(values: object, name: str, ndim: int) -> np.ndarray:
    """A contiguous float64 array of exactly ``ndim`` dimensions (values are not checked here)."""
    if hasattr(values, "heights") and hasattr(values, "dx"):   # a Profile or Surface where arrays are taken
        kind = type(values).__name__
        raise InvalidInputError(
            f"{name} is a roadtex {kind}, where the heights (m) are expected: pass its .heights and .dx (m), "
            f"e.g. roadtex.contact(p.heights, p.dx, youngs_modulus, mean_pressure); a {kind} with drop-outs "
            "(NaN) needs conditioning first (roadtex.profiles.conditioning.clean)")
    try:
        array = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be numeric: {exc}") from None
    if array.ndim != ndim:
        expected = {1: "a 1-D array (one profile)", 2: "a 2-D array (one segment per row, or a surface [iy, ix])",
                    3: "a 3-D array (a stack of surfaces [tile, iy, ix])"}.get(ndim, f"a {ndim}-D array")
        raise InvalidInputError(f"{name} must be {expected}, got an array of shape {array.shape}")
    return np.ascontiguousarray(array)


def to_float(value: object, name: str) -> float:
    """A float, NaN and inf included: for arguments the Rust core checks (and names) itself."""
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name} must be a number, got {value!r}") from None


def finite_number(value: object, name: str) -> float:
    """A finite float; booleans are refused (True is not a length)."""
    if isinstance(value, bool):
        raise InvalidInputError(f"{name} must be a number, got {value!r}")
    number = to_float(value, name)
    if not math.isfinite(number):
        raise InvalidInputError(f"{name} must be finite, got {value!r}")
    return number


def positive(value: object, name: str, unit: str = "m") -> float:
    """A finite float above zero; ``unit`` goes into the message, worded as the Rust core's."""
    if isinstance(value, bool):
        raise InvalidInputError(f"{name} must be a number, got {value!r}")
    number = to_float(value, name)
    if not (math.isfinite(number) and number > 0.0):
        raise InvalidInputError(f"{name} must be a positive finite number ({unit}), got {value!r}")
    return number


def fraction(value: object, name: str) -> float:
    """A finite float in [0, 1]."""
    number = finite_number(value, name)
    if not 0.0 <= number <= 1.0:
        raise InvalidInputError(f"{name} must be between 0 and 1, got {value!r}")
    return number


def whole_number(value: object, name: str, minimum: int) -> int:
    """An int (numpy integers too, booleans not) of at least ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or int(value) < minimum:
        raise InvalidInputError(f"{name} must be at least {minimum} (a whole number), got {value!r}")
    return int(value)


def positive_int(value: object, name: str) -> int:
    return whole_number(value, name, 1)


def poisson_ratio(value: object, name: str = "poisson") -> float:
    """A Poisson ratio in (-1, 0.5], the range of an isotropic elastic solid."""
    number = finite_number(value, name)
    if not -1.0 < number <= 0.5:
        raise InvalidInputError(f"{name} must lie in (-1, 0.5], got {value!r}")
    return number


def moduli_array(value: object) -> np.ndarray:
    """One Young's modulus or a 1-D sequence of them (Pa) as a float64 array (values checked by the core)."""
    moduli = np.atleast_1d(np.asarray(value, dtype=np.float64))
    if moduli.ndim != 1:
        raise InvalidInputError(f"youngs_modulus must be a number or a 1-D sequence, got shape {moduli.shape}")
    return moduli
