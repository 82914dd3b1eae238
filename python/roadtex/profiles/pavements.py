"""Synthetic road pavements for tests and the demo.

Synthetic profiles are built from the things a laser sees on a road: aggregate stones (rounded
caps of a given size distribution, laid one after another along the line), the binder or mortar
level between them, fine texture on top, and a little long-wave unevenness. The parameters are
physical (stone sizes, gaps, how deep the binder sits) and were set so that MPD and spectra land
where measured surfaces of each kind do; nothing is rescaled to hit a target.

Targets. Mean profile depth (ISO 13473-1) of each kind lands in the range typical of that surface
type; the texture spectrum (ISO 13473-4 levels, dB re 1 um, :func:`roadtex.spectra.third_octave_levels`)
peaks where the aggregate or the tining puts it:

- ``dense_asphalt`` (AC 0/11): MPD 0.5 to 1.0 mm (the generator gives about 0.8 mm); spectrum
  peaking at 6 to 12.5 mm, about 45 dB.
- ``porous_asphalt`` (PA 0/11 to 0/16): MPD 1.2 to 2.0 mm (about 1.6 mm), negative texture: a
  plateau of stone tops with deep narrow pores; peak at 10 to 20 mm.
- ``surface_dressing`` (chip seal, 8 to 16 mm chips): MPD 1.5 to 3.0 mm (about 2.1 mm), positive
  texture; peak at 10 to 25 mm near 55 to 60 dB. Real reference: the three CAPTIF chip seals in
  ``../shared/data/captif-slp`` measure MPD 3.0 to 3.4 mm and peak at 55 to 60 dB between 12.5 and
  63 mm (they are coarse and carry more megatexture).
- ``cement_concrete``: a mortar surface with exposed sand, MPD 0.3 to 0.6 mm (about 0.34 mm);
  with transverse tining (grooves about 3 mm wide and deep, 15 mm apart by default) 0.6 to 1.2 mm
  (about 0.7 mm), with a tonal peak in the band holding the tining spacing.

Sources for the MPD ranges: U. Sandberg and J. A. Ejsmont, *Tyre/Road Noise Reference Book*
(Informex, 2002), chapters on texture and on surface types; PIARC reports on surface
characteristics (typical MPD per surface type); FHWA guidance on concrete tining (widths, depths,
spacings); ISO 13473-1:2019 and ISO 13473-4:2008 for the definitions. The spectral peaks follow
from the geometry (aggregate size, tining spacing) and, for chip seal, from the CAPTIF
measurements; the published spectra vary by several dB between surfaces of one type, so treat the
levels as plausible, not as calibrated. These are typical values for new-ish surfaces, not
specifications.
"""

from __future__ import annotations

import numpy as np

from roadtex._checks import finite_number, positive
from roadtex.errors import InvalidInputError
from roadtex.profiles.profile import Profile

_KINDS = ("cement_concrete", "dense_asphalt", "porous_asphalt", "surface_dressing")

# Stone-layer parameters, all lengths in metres. stone sizes: chord length along the line, drawn as
# min + (max - min) * U**grading (grading > 1 favours small stones, as a continuous grading does);
# gap_mean and gap_shape: mean clear distance between stones and the shape of its gamma
# distribution (1: exponential, larger: more regular); top_sd: scatter of stone tops;
# aspect: vertical semi-axis / horizontal semi-axis of a stone's rounded cap; binder_depth: how
# far below the mean stone top the binder or mortar lies (the floor of the gaps); max_slope: the
# steepest descent the laser can follow (see _limit_slope), which also keeps synthetic surfaces
# clear of the ISO spike criterion (slope 3 at 0.5 mm); fine_sd and
# fine_correlation: the fine texture on everything; unevenness_sd: long-wave (> 100 mm) component.
_DEFAULTS: dict[str, dict[str, float | bool]] = {
    "dense_asphalt": dict(min_stone=2.0e-3, max_stone=11.0e-3, grading=1.6, gap_mean=1.2e-3, gap_shape=2.0,
                          top_sd=0.3e-3, aspect=0.4, binder_depth=0.9e-3, max_slope=2.0,
                          fine_sd=0.04e-3, fine_correlation=0.3e-3, unevenness_sd=0.2e-3),
    "porous_asphalt": dict(min_stone=6.0e-3, max_stone=14.0e-3, grading=1.0, gap_mean=3.0e-3, gap_shape=3.0,
                           top_sd=0.35e-3, aspect=0.35, binder_depth=7.0e-3, max_slope=2.5,
                           fine_sd=0.04e-3, fine_correlation=0.3e-3, unevenness_sd=0.2e-3),
    "surface_dressing": dict(min_stone=8.0e-3, max_stone=16.0e-3, grading=1.0, gap_mean=3.0e-3, gap_shape=2.0,
                             top_sd=0.7e-3, aspect=0.6, binder_depth=4.0e-3, max_slope=2.5,
                             fine_sd=0.05e-3, fine_correlation=0.3e-3, unevenness_sd=0.3e-3),
    "cement_concrete": dict(min_stone=0.5e-3, max_stone=2.5e-3, grading=1.5, gap_mean=1.0e-3, gap_shape=1.0,
                            top_sd=0.12e-3, aspect=0.5, binder_depth=0.35e-3, max_slope=2.5,
                            fine_sd=0.05e-3, fine_correlation=0.5e-3, unevenness_sd=0.08e-3,
                            tining=False, tining_spacing=15e-3, tining_spacing_jitter=0.1,
                            tining_width=3.0e-3, tining_depth=3.0e-3),
}


def synthetic_pavement(kind: str, length: float, dx: float, *, seed: int = 0, **options: float | bool) -> Profile:
    """A reproducible synthetic road profile of a given pavement type.

    Args:
        kind: ``"cement_concrete"``, ``"dense_asphalt"``, ``"porous_asphalt"`` or
            ``"surface_dressing"`` (chip seal); see the module docstring for what each targets.
        length: profile length (m), at least 10 dx.
        dx: sampling interval (m), e.g. 0.05e-3 for the contact model or 0.5e-3 for MPD.
        seed: the random seed; the same (kind, length, dx, seed, options) gives the same profile.
        options: override the stone-layer parameters of the kind (metres): ``min_stone``,
            ``max_stone``, ``grading``, ``gap_mean``, ``gap_shape``, ``top_sd``, ``aspect``, ``binder_depth``,
            ``max_slope`` (dimensionless, 0 for none), ``fine_sd``, ``fine_correlation``, ``unevenness_sd``; for cement concrete also
            ``tining`` (bool, transverse grooves), ``tining_spacing``, ``tining_spacing_jitter``
            (relative scatter of the spacing, which spreads the tonal peak), ``tining_width``,
            ``tining_depth``.

    Returns:
        A uniform :class:`Profile` (heights m, NaN-free, positions from 0) whose metadata names the
        kind, seed and parameters.
    """
    if kind not in _KINDS:
        raise InvalidInputError(f"unknown pavement kind {kind!r}; known kinds: {', '.join(_KINDS)}")
    length_f = positive(length, "length")
    dx_f = positive(dx, "dx")
    n = int(round(length_f / dx_f))
    if n < 10:
        raise InvalidInputError(f"length {length_f:g} m is fewer than 10 samples of dx {dx_f:g} m")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InvalidInputError(f"seed must be a non-negative whole number, got {seed!r}")
    parameters = dict(_DEFAULTS[kind])
    unknown = set(options) - set(parameters)
    if unknown:
        raise InvalidInputError(f"unknown option(s) {sorted(unknown)} for {kind}; known: {sorted(parameters)}")
    for key, value in options.items():
        if isinstance(parameters[key], bool):
            if not isinstance(value, (bool, np.bool_)):
                raise InvalidInputError(f"{key} must be True or False, got {value!r}")
            parameters[key] = bool(value)
        else:
            number = finite_number(value, key)
            if number < 0:
                raise InvalidInputError(f"{key} must be >= 0, got {value!r}")
            parameters[key] = number
    if parameters["min_stone"] <= 0 or parameters["max_stone"] < parameters["min_stone"]:
        raise InvalidInputError("need 0 < min_stone <= max_stone")

    rng = np.random.default_rng([int(seed), _KINDS.index(kind)])
    x = dx_f * np.arange(n)
    z = _stone_layer(x, rng, parameters)
    if kind == "cement_concrete" and parameters["tining"]:
        z = z - _tining(x, rng, parameters)
    z = _limit_slope(x, z, float(parameters["max_slope"]))
    z = z + _correlated_noise(n, dx_f, float(parameters["fine_correlation"]), rng) * float(parameters["fine_sd"])
    z = z + _correlated_noise(n, dx_f, 0.15, rng) * float(parameters["unevenness_sd"])
    z = z - z.mean()
    settings = ", ".join(f"{k}={v}" for k, v in options.items())
    step = (f"synthetic_pavement({kind!r}, length={length_f:g} m, dx={dx_f:g} m, seed={int(seed)}"
            f"{', ' + settings if settings else ''})")
    metadata: dict[str, object] = {"synthetic": True, "kind": kind, "seed": int(seed), "device": "roadtex.pavements",
                                   **{k: (bool(v) if isinstance(v, bool) else float(v)) for k, v in parameters.items()}}
    return Profile(z, x, dx_f, metadata, (step,))


def _stone_layer(x: np.ndarray, rng: np.random.Generator, p: dict) -> np.ndarray:
    """Stones laid one after another with gaps; heights of stone caps, binder level in the gaps."""
    total = float(x[-1] - x[0]) + 2 * float(p["max_stone"])
    mean_pitch = 0.5 * (p["min_stone"] + p["max_stone"]) + p["gap_mean"]
    count = int(total / mean_pitch * 1.3) + 16
    widths = p["min_stone"] + (p["max_stone"] - p["min_stone"]) * rng.random(count) ** p["grading"]
    gaps = _gaps(rng, p, count)
    tops = rng.normal(0.0, p["top_sd"], count)
    lefts = x[0] - p["max_stone"] * rng.random() + np.concatenate([[0.0], np.cumsum(widths + gaps)[:-1]])
    while lefts[-1] < x[-1]:  # the rare unlucky draw: lay more stones
        more = _stone_layer_extension(rng, p, lefts[-1] + widths[-1] + gaps[-1], count)
        widths, gaps, tops, lefts = (np.concatenate([a, b]) for a, b in zip((widths, gaps, tops, lefts), more))
    index = np.searchsorted(lefts, x, side="right") - 1
    u = (x - lefts[index]) / widths[index]  # 0..1 across the stone, beyond 1 in the gap after it
    inside = u <= 1.0
    half_width = 0.5 * widths[index]
    semi_axis = p["aspect"] * half_width
    across = np.clip(2.0 * u - 1.0, -1.0, 1.0)
    cap = tops[index] + semi_axis * (np.sqrt(1.0 - across * across) - 1.0)
    binder = -float(p["binder_depth"])
    return np.where(inside, np.maximum(cap, binder), binder)


def _stone_layer_extension(rng: np.random.Generator, p: dict, start: float, count: int):
    widths = p["min_stone"] + (p["max_stone"] - p["min_stone"]) * rng.random(count) ** p["grading"]
    gaps = _gaps(rng, p, count)
    tops = rng.normal(0.0, p["top_sd"], count)
    lefts = start + np.concatenate([[0.0], np.cumsum(widths + gaps)[:-1]])
    return widths, gaps, tops, lefts


def _gaps(rng: np.random.Generator, p: dict, count: int) -> np.ndarray:
    # gamma-distributed clear distances: shape 1 is a Poisson (exponential) laying; larger shapes
    # pack the stones more regularly, which keeps long-wave texture down as on real surfaces
    if p["gap_mean"] <= 0:
        return np.zeros(count)
    shape = max(float(p["gap_shape"]), 1e-3)
    return rng.gamma(shape, p["gap_mean"] / shape, count)


def _tining(x: np.ndarray, rng: np.random.Generator, p: dict) -> np.ndarray:
    """Depth of transverse tining grooves: rounded-bottom channels at jittered spacing."""
    spacing, width, depth = float(p["tining_spacing"]), float(p["tining_width"]), float(p["tining_depth"])
    if spacing <= width:
        raise InvalidInputError(f"tining_spacing ({spacing:g} m) must exceed tining_width ({width:g} m)")
    count = int((x[-1] - x[0]) / spacing * 1.5) + 4
    jitter = float(p["tining_spacing_jitter"])
    pitches = spacing * np.clip(1.0 + jitter * rng.uniform(-1.0, 1.0, count), 0.2, None)
    pitches = np.maximum(pitches, width * 1.2)
    centres = x[0] + spacing * rng.random() + np.concatenate([[0.0], np.cumsum(pitches)[:-1]])
    nearest = np.clip(np.searchsorted(centres, x), 1, centres.size - 1)
    offset = np.minimum(np.abs(x - centres[nearest - 1]), np.abs(x - centres[nearest]))
    # a groove is a flat-bottomed channel whose walls round off over a quarter of its width
    wall = 0.25 * width
    edge = np.clip((0.5 * width - offset) / wall, 0.0, 1.0)
    return depth * np.sin(0.5 * np.pi * edge) ** 2


def _limit_slope(x: np.ndarray, z: np.ndarray, slope: float) -> np.ndarray:
    """The least surface above z that never falls away steeper than ``slope`` from any point: a
    grey dilation by a cone, as a triangulating laser sees it (it cannot look down a narrow pore,
    and the spike criterion of ISO 13473-1 would reject what it cannot see). Computed exactly with
    two running maxima: max_j(z_j - s |x_i - x_j|) split into j <= i and j >= i."""
    if slope <= 0:
        return z
    forward = np.maximum.accumulate(z + slope * x) - slope * x
    backward = (np.maximum.accumulate((z - slope * x)[::-1]) + slope * x[::-1])[::-1]
    return np.maximum(forward, backward)


def _correlated_noise(n: int, dx: float, correlation: float, rng: np.random.Generator) -> np.ndarray:
    """Unit-variance Gaussian noise with a Gaussian autocorrelation of length ``correlation`` (m)."""
    white = rng.standard_normal(n)
    if correlation <= dx:
        return white
    k = np.fft.rfftfreq(n, dx)
    shaped = np.fft.irfft(np.fft.rfft(white) * np.exp(-(np.pi * k * correlation) ** 2 / 2.0), n)
    sd = shaped.std()
    return shaped / sd if sd > 0 else shaped
