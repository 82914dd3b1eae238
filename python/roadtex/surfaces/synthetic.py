"""Synthetic 3D road pavements: the line generator's pavements (:mod:`roadtex.profiles.pavements`)
as surfaces, for tests and the demo.

The same physical recipe, in two dimensions: aggregate stones are rounded ellipsoidal caps
(random size from the kind's grading, random elongation and orientation) laid in staggered rows
across the road with gamma-distributed clear gaps along it; the binder or mortar level fills the
gaps; a triangulating laser's view limits the descent slope (along and across); fine texture and a
little long-wave unevenness lie on everything; tined concrete gets transverse grooves (constant
across the road). The kinds' parameters are the line generator's (``_DEFAULTS``), so the options
are the same; two 2-D settings are added: ``row_pitch`` (distance between stone rows across the
road, as a fraction of the mean stone size) and ``elongation`` (spread of stone shapes).

Targets: the MPD (ISO 13473-1, :func:`roadtex.mpd`) of the surface's longitudinal lines lands in
the ranges the line generator targets (its module docstring): dense asphalt 0.5 to 1.0 mm, porous
asphalt 1.2 to 2.0 mm, surface dressing 1.5 to 3.0 mm, cement concrete 0.3 to 0.6 mm, tined
concrete 0.6 to 1.2 mm.
"""

from __future__ import annotations

import numpy as np

from roadtex._checks import finite_number, positive
from roadtex.errors import InvalidInputError
from roadtex.profiles.pavements import _DEFAULTS, _KINDS, _tining
from roadtex.surfaces.surface import Surface

#: The 2-D settings per kind: stone rows across the road every ``row_pitch`` x the mean stone size;
#: stones' across/along semi-axis ratio drawn from 1 -+ ``elongation``; ``depth_scale`` scales the
#: binder depth (a line crosses a stone off its crest, where it is lower than its top, so the
#: binder sits relatively deeper than along the line generator's crests).
SURFACE_DEFAULTS: dict[str, dict[str, float]] = {
    "dense_asphalt": dict(row_pitch=0.75, elongation=0.3, depth_scale=1.0),
    "porous_asphalt": dict(row_pitch=0.8, elongation=0.3, depth_scale=0.75),
    "surface_dressing": dict(row_pitch=0.8, elongation=0.3, depth_scale=1.0),
    "cement_concrete": dict(row_pitch=0.8, elongation=0.3, depth_scale=1.0),
}



def surface_grid(length: float, width: float, dx: float, dy: float | None, seed: object) -> tuple[float, float, int, int]:
    """A synthetic surface's spacings (m) and point counts along and across, checked (at least 10
    samples along; ``seed`` a non-negative whole number)."""
    dx_f = positive(dx, "dx")
    dy_f = dx_f if dy is None else positive(dy, "dy")
    nx = int(round(positive(length, "length") / dx_f))
    ny = max(1, int(round(positive(width, "width") / dy_f)))
    if nx < 10:
        raise InvalidInputError(f"length {length:g} m is fewer than 10 samples of dx {dx_f:g} m")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InvalidInputError(f"seed must be a non-negative whole number, got {seed!r}")
    return dx_f, dy_f, nx, ny

def synthetic_surface(kind: str, length: float, width: float, dx: float, dy: float | None = None, *,
                      seed: int = 0, **options: float | bool) -> Surface:
    """A reproducible synthetic road surface of a given pavement type.

    Args:
        kind: ``"cement_concrete"``, ``"dense_asphalt"``, ``"porous_asphalt"`` or
            ``"surface_dressing"`` (chip seal), as :func:`roadtex.profiles.synthetic_pavement`.
        length: length along the road (m), at least 10 dx.
        width: width across the road (m), at least one dy.
        dx: spacing along the road (m); ``dy``: across (m, default ``dx``).
        seed: the random seed; the same (kind, length, width, dx, dy, seed, options) gives the
            same surface.
        options: the line generator's stone-layer options (metres; ``tining=True`` and its
            settings for cement concrete) and the 2-D ones ``row_pitch``, ``elongation``,
            ``depth_scale`` (see the module docstring).

    Returns:
        A NaN-free :class:`Surface` (heights m, mean zero) whose metadata names kind, seed and parameters.
    """
    if kind not in _KINDS:
        raise InvalidInputError(f"unknown pavement kind {kind!r}; known kinds: {', '.join(_KINDS)}")
    dx_f, dy_f, nx, ny = surface_grid(length, width, dx, dy, seed)
    p: dict[str, float | bool] = {**_DEFAULTS[kind], **SURFACE_DEFAULTS[kind]}
    unknown = set(options) - set(p)
    if unknown:
        raise InvalidInputError(f"unknown option(s) {sorted(unknown)} for {kind}; known: {sorted(p)}")
    for key, value in options.items():
        if isinstance(p[key], bool):
            if not isinstance(value, (bool, np.bool_)):
                raise InvalidInputError(f"{key} must be True or False, got {value!r}")
            p[key] = bool(value)
        else:
            number = finite_number(value, key)
            if number < 0:
                raise InvalidInputError(f"{key} must be >= 0, got {value!r}")
            p[key] = number
    if p["min_stone"] <= 0 or p["max_stone"] < p["min_stone"] or p["row_pitch"] <= 0:
        raise InvalidInputError("need 0 < min_stone <= max_stone and row_pitch > 0")

    rng = np.random.default_rng([int(seed), _KINDS.index(kind), 3])
    x = dx_f * np.arange(nx)
    z = stone_layer(nx, ny, dx_f, dy_f, rng, p)
    if kind == "cement_concrete" and p["tining"]:
        z -= _tining(x, rng, p)[None, :]
    z = limit_slope(z, dx_f, dy_f, float(p["max_slope"]))
    z += correlated_noise((ny, nx), dx_f, dy_f, float(p["fine_correlation"]), rng) * float(p["fine_sd"])
    z += correlated_noise((ny, nx), dx_f, dy_f, 0.15, rng) * float(p["unevenness_sd"])
    z -= z.mean()
    settings = ", ".join(f"{k}={v}" for k, v in options.items())
    step = (f"synthetic_surface({kind!r}, length={nx * dx_f:g} m, width={ny * dy_f:g} m, dx={dx_f:g} m, "
            f"dy={dy_f:g} m, seed={int(seed)}{', ' + settings if settings else ''})")
    metadata: dict[str, object] = {"synthetic": True, "kind": kind, "seed": int(seed), "device": "roadtex.surfaces",
                                   **{k: (bool(v) if isinstance(v, bool) else float(v)) for k, v in p.items()}}
    return Surface(z, dx_f, dy_f, metadata, (step,))


def stone_layer(nx: int, ny: int, dx: float, dy: float, rng: np.random.Generator, p: dict) -> np.ndarray:
    """Ellipsoidal stone caps in staggered rows across the road, the binder level between them."""
    binder = -float(p["binder_depth"]) * float(p["depth_scale"])
    z = np.full((ny, nx), binder)
    lo, hi = float(p["min_stone"]), float(p["max_stone"])
    mean_size = lo + (hi - lo) / (1.0 + float(p["grading"]))
    pitch_y = float(p["row_pitch"]) * mean_size
    total_x, total_y = nx * dx + 2 * hi, ny * dy + 2 * hi
    n_rows = int(total_y / pitch_y) + 2
    per_row = int(total_x / (mean_size + float(p["gap_mean"])) * 1.3) + 8
    shape = max(float(p["gap_shape"]), 1e-3)
    stones = []
    for row in range(n_rows):
        sizes = lo + (hi - lo) * rng.random(per_row) ** float(p["grading"])
        gaps = rng.gamma(shape, float(p["gap_mean"]) / shape, per_row) if p["gap_mean"] > 0 else np.zeros(per_row)
        lefts = -hi - hi * rng.random() + np.concatenate([[0.0], np.cumsum(sizes + gaps)[:-1]])
        centres_x = lefts + 0.5 * sizes
        centres_y = -hi + (row + 0.5) * pitch_y + 0.25 * pitch_y * rng.uniform(-1.0, 1.0, per_row)
        ratios = 1.0 + float(p["elongation"]) * rng.uniform(-1.0, 1.0, per_row)
        angles = rng.uniform(0.0, np.pi, per_row)
        tops = rng.normal(0.0, float(p["top_sd"]), per_row)
        keep = centres_x - hi < nx * dx
        stones.append(np.column_stack([centres_x, centres_y, 0.5 * sizes, 0.5 * sizes * ratios, angles, tops])[keep])
    draw_stones(z, dx, dy, np.concatenate(stones), float(p["aspect"]))
    return z


def draw_stones(z: np.ndarray, dx: float, dy: float, stones: np.ndarray, aspect: float) -> None:
    """Raises ``z`` to the caps of ellipsoidal stones, in place. ``stones`` rows: centre x, y,
    horizontal semi-axes a (along before rotation), b, rotation angle, crest height (all m; angle
    rad); the vertical semi-axis is ``aspect`` x a. Stones are drawn in batches on padded bounding
    boxes (the larger ones first), overlaps resolved by the maximum."""
    order = np.argsort(-np.maximum(stones[:, 2], stones[:, 3]), kind="stable")
    stones = stones[order]
    flat = z.reshape(-1)
    ny, nx = z.shape
    start = 0
    while start < len(stones):
        reach = float(np.max(stones[start, 2:4]))
        rx, ry = int(np.ceil(reach / dx)) + 1, int(np.ceil(reach / dy)) + 1
        box = (2 * ry + 1) * (2 * rx + 1)
        batch = stones[start:start + max(1, 2_000_000 // box)]
        start += len(batch)
        cx, cy, a, b, angle, top = (batch[:, k][:, None, None] for k in range(6))
        i = np.rint(cx / dx).astype(np.int64) + np.arange(-rx, rx + 1)[None, None, :]
        j = np.rint(cy / dy).astype(np.int64) + np.arange(-ry, ry + 1)[None, :, None]
        u, v = dx * i - cx, dy * j - cy
        cos, sin = np.cos(angle), np.sin(angle)
        q = ((u * cos + v * sin) / a) ** 2 + ((v * cos - u * sin) / b) ** 2
        inside = (q <= 1.0) & (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
        cap = top + aspect * a * (np.sqrt(np.clip(1.0 - q, 0.0, None)) - 1.0)
        index = np.broadcast_to(j * nx + i, q.shape)[inside]
        np.maximum.at(flat, index, cap[inside])


def limit_slope(z: np.ndarray, dx: float, dy: float, slope: float) -> np.ndarray:
    """The least surface above z that never falls away steeper than ``slope`` along x or across y
    from any point (a grey dilation by a pyramid: the 1-D cone of the line generator along the
    rows, then down the columns), as a triangulating laser sees it."""
    if slope <= 0:
        return z
    out = z
    for axis, step in ((1, dx), (0, dy)):
        n = out.shape[axis]
        if n < 2:
            continue
        s = slope * step * np.arange(n)
        s = s[None, :] if axis == 1 else s[:, None]
        forward = np.maximum.accumulate(out + s, axis=axis) - s
        flipped = np.flip(out - s, axis=axis)
        backward = np.flip(np.maximum.accumulate(flipped, axis=axis), axis=axis) + s
        out = np.maximum(forward, backward)
    return out


def correlated_noise(shape: tuple[int, int], dx: float, dy: float, correlation: float,
                     rng: np.random.Generator) -> np.ndarray:
    """Unit-variance Gaussian noise with a Gaussian autocorrelation of length ``correlation`` (m)."""
    white = rng.standard_normal(shape)
    if correlation <= min(dx, dy):
        return white
    kx = np.fft.rfftfreq(shape[1], dx)[None, :]
    ky = np.fft.fftfreq(shape[0], dy)[:, None]
    filt = np.exp(-(np.pi * correlation) ** 2 * (kx * kx + ky * ky) / 2.0)
    shaped = np.fft.irfft2(np.fft.rfft2(white) * filt, shape)
    sd = shaped.std()
    return shaped / sd if sd > 0 else shaped


#: Defaults of :func:`sett_surface` (m; ``*_sd`` standard deviations, ``tilt_sd`` a slope): a
#: Belgian-block (sett) pavement as laid in cities, granite setts of about 15 cm along the road
#: by 10 cm across in courses across the road, each course offset from the last (stretcher bond),
#: joints 1 to 2 cm wide filled with sand or mortar a few mm to 1 cm below the setts' edges.
SETT_DEFAULTS: dict[str, float] = dict(
    sett_length=0.15, sett_width=0.10, size_spread=0.05, joint_min=0.010, joint_max=0.020,
    joint_depth_min=0.003, joint_depth_max=0.010, crown=0.002, top_sd=0.0007, tilt_sd=0.004,
    edge_radius=0.004, roughness_sd=0.0003)


def sett_surface(length: float, width: float, dx: float = 0.01, dy: float | None = None, *, seed: int = 0,
                 **options: float) -> Surface:
    """A reproducible synthetic Belgian-block (sett) surface: the coarse pavement that OpenCRG road
    files describe at 1 cm and more (the cobblestones of old city streets and test tracks).

    Courses of setts run across the road, one after another along it: course ``k`` is a sett
    length along the road (``sett_length`` x (1 -+ ``size_spread``)), its setts ``sett_width`` (same
    spread) across, the course's transverse joints offset by about half a sett from the previous
    course's. Every joint is ``joint_min`` to ``joint_max`` wide (uniform) and its fill lies
    ``joint_depth_min`` to ``joint_depth_max`` below the setts' edges (uniform, one depth per joint).
    Each sett's top is a dome ``crown`` high at its centre above its edges (parabolic both ways),
    raised by a random level (``top_sd``) and tilted (slopes ``tilt_sd`` each way), its arrises
    rounded (radius ``edge_radius``); white roughness (``roughness_sd``) lies on setts and joints.

    Args:
        length: length along the road (m), at least 10 dx.
        width: width across the road (m), at least one dy.
        dx: spacing along the road (m, default 1 cm); ``dy``: across (m, default ``dx``).
        seed: the random seed; the same arguments give the same surface.
        options: any of :data:`SETT_DEFAULTS` (m, ``size_spread`` a fraction, ``tilt_sd`` a slope).

    Returns:
        A NaN-free :class:`Surface` (heights m, mean zero) whose metadata names the settings and the
        mean sett pitch along the road (m).
    """
    dx_f, dy_f, nx, ny = surface_grid(length, width, dx, dy, seed)
    unknown = set(options) - set(SETT_DEFAULTS)
    if unknown:
        raise InvalidInputError(f"unknown option(s) {sorted(unknown)} for sett_surface; known: {sorted(SETT_DEFAULTS)}")
    p = {**SETT_DEFAULTS, **{k: finite_number(v, k) for k, v in options.items()}}
    if any(v < 0 for v in p.values()):
        raise InvalidInputError(f"sett_surface options must be >= 0, got {options!r}")
    if (p["sett_length"] <= 0 or p["sett_width"] <= 0 or not 0 <= p["size_spread"] < 1
            or p["joint_max"] < p["joint_min"] or p["joint_depth_max"] < p["joint_depth_min"]):
        raise InvalidInputError("need sett_length, sett_width > 0, 0 <= size_spread < 1, joint_min <= joint_max "
                                "and joint_depth_min <= joint_depth_max")
    rng = np.random.default_rng([int(seed), 7, 11])
    x = dx_f * np.arange(nx)
    y = dy_f * np.arange(ny)
    z = np.empty((ny, nx))

    def sizes(mean: float, count: int) -> np.ndarray:
        return mean * (1.0 + p["size_spread"] * rng.uniform(-1.0, 1.0, count))

    def joints(count: int) -> tuple[np.ndarray, np.ndarray]:
        return rng.uniform(p["joint_min"], p["joint_max"], count), rng.uniform(p["joint_depth_min"],
                                                                               p["joint_depth_max"], count)

    start = -p["sett_length"] * rng.random()   # the first course begins before x = 0
    offset = p["sett_width"] * rng.random()
    pitches = []
    while start < x[-1] + dx_f:
        course = float(sizes(p["sett_length"], 1)[0])
        joint_width, joint_depth = (float(v[0]) for v in joints(1))
        columns = (x >= start) & (x < start + course + joint_width)
        u = x[columns] - start                                        # along the course, from its start
        # stretcher bond: about half a sett across from the previous course's joints
        offset = (offset + 0.5 * p["sett_width"] * (1.0 + 0.2 * rng.uniform(-1.0, 1.0))) % p["sett_width"]
        count = int(np.ceil((y[-1] + dy_f + offset) / (p["sett_width"] + p["joint_min"]))) + 1
        widths, (gaps, gap_depths) = sizes(p["sett_width"], count), joints(count)
        lefts = -offset + np.concatenate([[0.0], np.cumsum(widths + gaps)[:-1]])
        sett = np.clip(np.searchsorted(lefts, y, side="right") - 1, 0, count - 1)
        v = y - lefts[sett]                                            # across the sett, from its right edge
        in_gap = v >= widths[sett]
        level = rng.normal(0.0, p["top_sd"], count)[sett][:, None]
        tilt_u = rng.normal(0.0, p["tilt_sd"], count)[sett][:, None]
        tilt_v = rng.normal(0.0, p["tilt_sd"], count)[sett][:, None]
        su = np.clip(u / course, 0.0, 1.0)[None, :]                    # 0 to 1 over the sett
        sv = np.clip(v / widths[sett], 0.0, 1.0)[:, None]
        dome = p["crown"] * (1.0 - (2.0 * su - 1.0) ** 2) * (1.0 - (2.0 * sv - 1.0) ** 2)
        edge = np.minimum(np.minimum(u, course - u)[None, :], np.minimum(v, widths[sett] - v)[:, None])
        r = p["edge_radius"]
        rounding = np.where(edge < r, r - np.sqrt(np.clip(r * r - (r - np.clip(edge, 0.0, r)) ** 2, 0.0, None)), 0.0)
        top = (level + dome + tilt_u * (u[None, :] - 0.5 * course) + tilt_v * (v - 0.5 * widths[sett])[:, None]
               - rounding)
        in_joint = (u >= course)[None, :] | in_gap[:, None]
        depth = np.where((u >= course)[None, :], -joint_depth, -gap_depths[sett][:, None])
        z[:, columns] = np.where(in_joint, depth, top)
        pitches.append(course + joint_width)
        start += course + joint_width
    z += rng.normal(0.0, p["roughness_sd"], z.shape)
    z -= z.mean()
    settings = ", ".join(f"{k}={v}" for k, v in options.items())
    step = (f"sett_surface(length={nx * dx_f:g} m, width={ny * dy_f:g} m, dx={dx_f:g} m, dy={dy_f:g} m, "
            f"seed={int(seed)}{', ' + settings if settings else ''})")
    metadata: dict[str, object] = {"synthetic": True, "kind": "setts", "seed": int(seed), "device": "roadtex.surfaces",
                                   "mean_pitch": float(np.mean(pitches)), **{k: float(v) for k, v in p.items()}}
    return Surface(z, dx_f, dy_f, metadata, (step,))
