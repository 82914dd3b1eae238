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


def real_values(values: object, name: str, *, masked: str = "refuse") -> object:
    """``values`` ready for a float64 conversion that loses nothing silently: complex values are
    refused (numpy would drop the imaginary part with only a warning), and a ``numpy.ma`` masked
    array's masked values either refused (``masked="refuse"``: a solver has no drop-outs) or made
    NaN drop-outs (``masked="dropouts"``: a profile or surface), never converted as if valid (a
    masked -0.85 m drop-out code would be solved as road)."""
    try:
        complex_values = np.iscomplexobj(values)
    except (TypeError, ValueError):   # ragged or not numeric: the conversion says so
        return values
    if complex_values:
        raise InvalidInputError(f"{name} must be real numbers, got complex values (dtype "
                                f"{np.asarray(values).dtype}); pass .real if the imaginary part is meant to go")
    if isinstance(values, np.ma.MaskedArray):
        hidden = int(np.ma.count_masked(values))
        if hidden and masked == "refuse":
            raise InvalidInputError(f"{name} is a masked array with {hidden} masked value(s): the solvers take no "
                                    "drop-outs; fill them first (e.g. Profile(heights.filled(np.nan), ...)"
                                    ".fill_dropouts()), or pass the data without them")
        return np.ma.filled(values.astype(np.float64), np.nan)
    return values


def as_float_array(values: object, name: str, ndim: int) -> np.ndarray:
    """A contiguous float64 array of exactly ``ndim`` dimensions (values are not checked here;
    complex and masked values are refused, see :func:`real_values`)."""
    if hasattr(values, "heights") and hasattr(values, "dx"):   # a Profile or Surface where arrays are taken
        kind = type(values).__name__
        raise InvalidInputError(
            f"{name} is a roadtex {kind}, where the heights (m) are expected: pass its .heights and .dx (m), "
            f"e.g. roadtex.contact(p.heights, p.dx, youngs_modulus, mean_pressure); a {kind} with drop-outs "
            "(NaN) needs conditioning first (roadtex.profiles.conditioning.clean)")
    values = real_values(values, name)
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
    """A float, NaN and inf included: for arguments the Rust core checks (and names) itself.
    Text and booleans are refused: float("1e-4") and float(True) would hide a caller's mistake."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise InvalidInputError(f"{name} must be a number, got {value!r}")
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


#: The most worker threads a call may ask for is this many times the usable cores (with a floor of
#: :data:`MIN_THREAD_LIMIT`): the solves are CPU-bound, so threads beyond the cores only contend
#: for them (10,000 threads on 4 x 1,024 points took 97 s against 0.003 s on 2, at a load of 1,500);
#: 4x leaves room for cores a container under-reports.
THREADS_PER_CORE_LIMIT = 4
#: The thread limit's floor: a fixed count a script or test asks for (8, 16, 64) stays valid on a
#: small machine, at a bounded cost (each rayon thread a kernel task and a stack reservation).
MIN_THREAD_LIMIT = 64


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity where the platform has one)."""
    import os

    try:
        return len(os.sched_getaffinity(0))   # portable: guarded (AttributeError off Linux)
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def thread_count(value: object, name: str = "threads") -> int | None:
    """None (all cores), or a whole number from 1 to the thread limit (see
    :data:`THREADS_PER_CORE_LIMIT`); refused above it, naming the limit and the cores."""
    if value is None:
        return None
    threads = positive_int(value, name)
    cores = usable_cores()
    limit = max(MIN_THREAD_LIMIT, THREADS_PER_CORE_LIMIT * cores)
    if threads > limit:
        raise InvalidInputError(f"{name} = {threads} is more than {limit} ({THREADS_PER_CORE_LIMIT} per usable core, "
                                f"{cores} here, and at least {MIN_THREAD_LIMIT}): the solves are CPU-bound, so "
                                "threads beyond the cores only slow them (None uses every core)")
    return threads


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


def required(value: object, name: str, unit: str) -> object:
    """``value``, refused when None (an argument that has a default only so that a Profile may be
    given without its dx before it)."""
    if value is None:
        raise InvalidInputError(f"{name} ({unit}) is required")
    return value


def spacing_of(values: object, dx: object, name: str, dy: object = None, *,
               surface: bool = False) -> tuple[object, float, float | None]:
    """(heights, dx, dy) of what a public function was given: a :class:`~roadtex.Profile` (its
    heights and dx; ``surface=False``), a :class:`~roadtex.Surface` (its heights, dx and dy;
    ``surface=True``), or an array of heights with its spacing(s) in metres. A spacing given with a
    Profile or Surface must be the one it carries (to 1e-9 of it): two different spacings are a
    mistake, not a choice; a Profile whose readings are not equally spaced is refused (resample it).
    ``dy`` is None where a surface array is given without one."""
    # known by what they carry, not by their classes: this module is below roadtex.profiles and
    # roadtex.surfaces, which import it (a Surface carries dy, a Profile does not)
    carried_kind = ("Surface" if hasattr(values, "dy") else "Profile") if (
        hasattr(values, "heights") and hasattr(values, "dx")) else None
    kind = "Surface" if surface else "Profile"
    if carried_kind is not None and carried_kind != kind:
        wanted = "a Surface (or a 2-D array)" if surface else "a Profile (or a 1-D array)"
        raise InvalidInputError(f"{name} is a {type(values).__name__}; this function takes {wanted}")
    if carried_kind is None:
        if dx is None:
            raise InvalidInputError(f"dx (m) is required with an array of {name} (a {kind} carries its own)")
        return values, to_float(dx, "dx"), None if dy is None else to_float(dy, "dy")
    if kind == "Profile" and not getattr(values, "is_uniform", True):
        raise InvalidInputError(f"{name}: the Profile's readings are not equally spaced (dx {values.dx:g} m); "
                                "resample it first (Profile.resample)")
    carried = {"dx": float(values.dx)} | ({"dy": float(values.dy)} if surface else {})
    for key, given in (("dx", dx), ("dy", dy)):
        if given is None or key not in carried:
            continue
        value = to_float(given, key)
        if abs(value - carried[key]) > 1e-9 * carried[key]:
            raise InvalidInputError(f"{key} {value:g} m was given for a {kind} whose {key} is "
                                    f"{carried[key]:g} m: leave {key} out (the {kind} carries it)")
    if not surface and dy is not None:
        raise InvalidInputError("dy is not an argument for a Profile")
    return values.heights, carried["dx"], carried.get("dy")
