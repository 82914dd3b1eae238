"""The road surface: a grid of heights in metres, with what produced it.

A :class:`Surface` holds ``heights[iy, ix]`` (m): rows run across the road (y, spacing ``dy``),
columns along it (x, spacing ``dx``), as for line profiles; NaN marks drop-outs. Every
conditioning step returns a new surface and appends a line to its ``history``.

The steps live in :mod:`roadtex.surfaces.conditioning`, tiles for the areal model in
:mod:`roadtex.surfaces.tiles`, readers in :mod:`roadtex.surfaces.readers`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable

import numpy as np

from roadtex._checks import finite_number, positive, real_values
from roadtex.errors import InvalidInputError
from roadtex.profiles.profile import MAX_MAGNITUDE, Profile, frozen
from roadtex.surfaces import conditioning
from roadtex.surfaces.tiles import Tiles, cut_tiles


def as_2d(values: object, name: str) -> np.ndarray:
    """A float64 copy of ``values``, refused unless it is 2-D and numeric."""
    values = real_values(values, name, masked="dropouts")   # masked values are drop-outs (NaN); complex refused
    try:
        array = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be numeric: {exc}") from None
    if array.ndim != 2:
        raise InvalidInputError(f"{name} must be a 2-D array [rows across the road, columns along it], "
                                f"got an array of shape {array.shape}")
    return array


@dataclass(frozen=True)
class Surface:
    """A measured (or synthetic) road surface on a regular grid.

    Attributes:
        heights: ``heights[iy, ix]`` (m), positive up, float64: rows across the road (y), columns
            along it (x); NaN marks a drop-out.
        dx: spacing of the columns along the road (m).
        dy: spacing of the rows across the road (m).
        metadata: what the source says about the measurement (plain JSON types).
        history: one human-readable line per step that produced this surface.
        x0, y0: position (m) of the first column and of the first row.

    Arrays are read-only; every method returns a new :class:`Surface`.
    """

    heights: np.ndarray
    dx: float
    dy: float
    metadata: dict[str, object] = field(default_factory=dict)
    history: tuple[str, ...] = ()
    x0: float = 0.0
    y0: float = 0.0

    def __post_init__(self) -> None:
        heights = as_2d(self.heights, "heights")
        if heights.shape[1] < 2:
            raise InvalidInputError(f"a surface needs at least 2 columns along the road, got shape {heights.shape}")
        if heights.shape[0] < 1:
            raise InvalidInputError("a surface needs at least 1 row")
        if np.isinf(heights).any():
            iy, ix = (int(i) for i in np.argwhere(np.isinf(heights))[0])
            raise InvalidInputError(f"heights contain inf at row {iy}, column {ix} (overflow in the source?); "
                                    "drop-outs must be NaN")
        if np.isnan(heights).all():
            raise InvalidInputError("all heights are NaN (drop-outs): no valid reading in the surface")
        biggest = float(np.nanmax(np.abs(heights)))
        if biggest > MAX_MAGNITUDE:
            raise InvalidInputError(f"a height of {biggest:.3g} m is beyond {MAX_MAGNITUDE:.0g} m: not a road surface "
                                    "(wrong unit or a corrupt file?)")
        object.__setattr__(self, "heights", frozen(heights))
        object.__setattr__(self, "dx", positive(self.dx, "dx"))
        object.__setattr__(self, "dy", positive(self.dy, "dy"))
        object.__setattr__(self, "x0", finite_number(self.x0, "x0"))
        object.__setattr__(self, "y0", finite_number(self.y0, "y0"))
        object.__setattr__(self, "metadata", dict(self.metadata))
        object.__setattr__(self, "history", tuple(str(h) for h in self.history))

    @classmethod
    def from_heights(cls, heights: np.ndarray, dx: float, dy: float | None = None, *,
                     metadata: dict[str, object] | None = None, history: Iterable[str] = ()) -> "Surface":
        """A surface from ``heights[iy, ix]`` (m) with spacings ``dx`` along and ``dy`` across (m;
        ``dy`` defaults to ``dx``), starting at x = y = 0."""
        return cls(heights, dx, dx if dy is None else dy, dict(metadata or {}), tuple(history))

    def derive(self, heights: np.ndarray, *, dx: float | None = None, dy: float | None = None,
               x0: float | None = None, y0: float | None = None, step: str = "") -> "Surface":
        """A new surface from a step of this one (heights m, spacings and origin m, one history
        line); the steps keep the invariants, so the checks of __init__ are skipped."""
        new = object.__new__(Surface)
        for name, value in (("heights", frozen(np.ascontiguousarray(heights, dtype=np.float64))),
                            ("dx", float(self.dx if dx is None else dx)), ("dy", float(self.dy if dy is None else dy)),
                            ("metadata", dict(self.metadata)), ("history", self.history + ((step,) if step else ())),
                            ("x0", float(self.x0 if x0 is None else x0)), ("y0", float(self.y0 if y0 is None else y0))):
            object.__setattr__(new, name, value)
        return new

    # ---------------------------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        """(rows across, columns along)."""
        return (int(self.heights.shape[0]), int(self.heights.shape[1]))

    @property
    def x(self) -> np.ndarray:
        """Positions of the columns along the road (m)."""
        return self.x0 + self.dx * np.arange(self.heights.shape[1])

    @property
    def y(self) -> np.ndarray:
        """Positions of the rows across the road (m)."""
        return self.y0 + self.dy * np.arange(self.heights.shape[0])

    @property
    def length(self) -> float:
        """Length along the road (m): columns x dx."""
        return float(self.heights.shape[1] * self.dx)

    @property
    def width(self) -> float:
        """Width across the road (m): rows x dy."""
        return float(self.heights.shape[0] * self.dy)

    @property
    def dropout_fraction(self) -> float:
        """Share of the readings that are drop-outs (NaN), 0..1."""
        return float(np.count_nonzero(np.isnan(self.heights)) / self.heights.size)

    # ---------------------------------------------------------------------------------------------
    def fill_dropouts(self) -> "Surface":
        """Drop-outs (NaN) filled by linear interpolation along each row (leading and trailing ones
        take the row's first or last valid height); rows without any valid reading are then
        interpolated across, column by column, from the nearest rows."""
        return conditioning.fill_dropouts(self)

    def remove_spikes(self, alpha: float = 3.0) -> "Surface":
        """Flags spikes as drop-outs (NaN) with the sampling-independent criterion of the line
        profiles (:func:`roadtex.profiles.conditioning.spike_mask`): a reading at least
        ``alpha`` x 0.5 mm from the median of the readings within 0.5 mm of it, both over the
        surface (an elliptical window of 0.5 mm radius in x and y, at least one neighbour each way)
        and along its row; see :func:`roadtex.surfaces.conditioning.spike_mask`. Stone edges and
        their corners are kept."""
        return conditioning.remove_spikes(self, alpha)

    def remove_plane(self) -> "Surface":
        """The least-squares plane z = a + b x + c y of the valid readings removed (m)."""
        return conditioning.remove_plane(self)

    def resample(self, dx: float, dy: float | None = None) -> "Surface":
        """A surface of spacings ``dx`` along and ``dy`` across (m; ``dy`` defaults to ``dx``),
        each new height the mean of the valid readings in its rectangle (interval averaging in both
        directions, as :meth:`roadtex.profiles.Profile.resample` does along a line). Each reading
        stands for a dx x dy cell; the new grid starts at the surface's corner; a rectangle with no
        valid reading is a drop-out. Resampling at the surface's own spacings is the identity; a
        spacing finer than the surface's is refused (InvalidInputError): averaging cannot refine."""
        return conditioning.resample(self, dx, dx if dy is None else dy)

    def lines(self, rows: Iterable[int] | None = None, every: int | None = None,
              wheel_paths: Iterable[float] | None = None) -> list[Profile]:
        """Longitudinal lines of the surface as :class:`~roadtex.profiles.Profile` objects.

        Give at most one of: ``rows`` (row indices), ``every`` (every k-th row from row 0) or
        ``wheel_paths`` (lateral positions y, m: the row nearest each). Without any, every row.
        Each profile carries the row's heights (m, drop-outs as NaN), positions ``x`` (m), and
        metadata ``row`` and ``y`` (m) besides the surface's.
        """
        chosen = [rows is not None, every is not None, wheel_paths is not None]
        if sum(chosen) > 1:
            raise InvalidInputError("give at most one of rows, every and wheel_paths")
        n_rows = self.heights.shape[0]
        if every is not None:
            if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
                raise InvalidInputError(f"every must be a whole number >= 1, got {every!r}")
            picked = list(range(0, n_rows, int(every)))
        elif wheel_paths is not None:
            picked = []
            for y in wheel_paths:
                y_f = finite_number(y, "wheel path position")
                row = int(round((y_f - self.y0) / self.dy))
                if not 0 <= row < n_rows:
                    raise InvalidInputError(f"wheel path at y = {y_f:.6g} m lies outside the surface "
                                            f"({self.y0:.6g}..{self.y0 + (n_rows - 1) * self.dy:.6g} m)")
                picked.append(row)
        elif rows is not None:
            picked = [int(r) for r in rows]
            for r in picked:
                if not -n_rows <= r < n_rows:
                    raise InvalidInputError(f"row {r} is outside the surface's {n_rows} rows")
            picked = [r % n_rows for r in picked]
        else:
            picked = list(range(n_rows))
        x = self.x
        profiles = []
        for row in picked:
            z = self.heights[row]
            if np.isnan(z).all():
                raise InvalidInputError(f"row {row} holds only drop-outs: fill_dropouts() first")
            metadata = {**self.metadata, "row": row, "y": float(self.y0 + row * self.dy)}
            step = f"Surface.lines(): row {row} (y = {self.y0 + row * self.dy:.6g} m)"
            profiles.append(Profile(z.copy(), x, self.dx, metadata, self.history + (step,)))
        return profiles

    def tiles(self, length: float, width: float, overlap: float | tuple[float, float] = 0.0, *,
              detrend: bool = True) -> Tiles:
        """Footprint-sized tiles for the areal contact model; see :func:`roadtex.surfaces.tiles.cut_tiles`.

        Args:
            length: tile length along the road (m).
            width: tile width across the road (m).
            overlap: overlap of neighbouring tiles (m), one number for both directions or
                (along, across). Tiles start every (length - overlap); the last one in each
                direction is moved back to end at the surface's edge.
            detrend: remove each tile's least-squares plane (kept in ``Tiles.trends``).

        The surface must be free of drop-outs (:meth:`fill_dropouts`). ``Tiles.stitch`` puts
        per-tile results back into one surface-sized array without seams.
        """
        return cut_tiles(self, length, width, overlap, detrend=detrend)
