"""Footprint-sized tiles of a surface for the areal contact model, and stitching per-tile results
back into one surface without seams (the 2-D counterpart of :mod:`roadtex.profiles.segments`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from roadtex._checks import finite_number, positive
from roadtex.errors import InvalidInputError

if TYPE_CHECKING:
    from roadtex.surfaces.surface import Surface


@dataclass(frozen=True)
class Tiles:
    """Equal tiles of a surface, a stack for the areal contact model.

    Attributes:
        heights: (n_tiles, rows, columns) heights (m), NaN-free, each tile's least-squares plane
            removed unless ``detrend=False`` was asked.
        trends: the plane removed from each tile (m; zeros when not detrended):
            ``heights + trends`` are the surface's own heights.
        row_starts, column_starts: (n_tiles,) index of each tile's first row and column in the surface.
        dx, dy: spacings along and across (m).
        length, width: tile size along and across (m: columns x dx, rows x dy).
        overlap: (along, across) nominal overlap of neighbouring tiles (m).
        surface_shape: (rows, columns) of the surface the tiles were cut from.
        x0, y0: the surface's origin (m), for positions.
    """

    heights: np.ndarray
    trends: np.ndarray
    row_starts: np.ndarray
    column_starts: np.ndarray
    dx: float
    dy: float
    length: float
    width: float
    overlap: tuple[float, float]
    surface_shape: tuple[int, int]
    x0: float = 0.0
    y0: float = 0.0

    def __len__(self) -> int:
        return int(self.heights.shape[0])

    @property
    def starts(self) -> np.ndarray:
        """(n_tiles, 2) position (m) of each tile's first column (x) and first row (y)."""
        return np.column_stack([self.x0 + self.dx * self.column_starts, self.y0 + self.dy * self.row_starts])

    def stitch(self, tile_values: np.ndarray, *, add_trend: bool = False) -> np.ndarray:
        """One seamless surface-sized array from per-tile results.

        Where tiles overlap, each tile's value is weighted by the product of its distances (in
        samples, from 0.5 at the edge) from its own nearest edges along and across, each ramp
        rising linearly over the overlap and then flat at 1 (a cross-fade, as
        :meth:`roadtex.profiles.Segments.stitch` does along a line): the result is continuous and
        values near a tile's edges, where the periodic model sees its seam, count least. Without
        overlap the tiles are simply put side by side.

        Args:
            tile_values: (n_tiles, rows, columns) results, e.g. envelopes (m) or pressures (Pa).
            add_trend: add back each tile's removed plane, for heights or envelopes in the
                surface's frame (not for pressures).

        Returns:
            ``values[iy, ix]`` with the surface's shape.
        """
        array = np.asarray(tile_values, dtype=np.float64)
        if array.shape != self.heights.shape:
            raise InvalidInputError(f"tile_values must have shape {self.heights.shape} (tiles, rows, columns), "
                                    f"got {array.shape}")
        if add_trend:
            array = array + self.trends
        _, rows, columns = array.shape
        wy = ramp(rows, self.overlap[1] / self.dy)
        wx = ramp(columns, self.overlap[0] / self.dx)
        weight = wy[:, None] * wx[None, :]
        total = np.zeros(self.surface_shape)
        norm = np.zeros(self.surface_shape)
        for values, r0, c0 in zip(array, self.row_starts, self.column_starts):
            window = (slice(int(r0), int(r0) + rows), slice(int(c0), int(c0) + columns))
            total[window] += weight * values
            norm[window] += weight
        return total / norm


def ramp(n: int, overlap_samples: float) -> np.ndarray:
    """Cross-fade weights of ``n`` samples: distance from the nearest end (0.5 at the end sample)
    over the overlap, capped at 1."""
    edge = np.minimum(np.arange(n), np.arange(n)[::-1]) + 0.5
    return np.minimum(edge / max(overlap_samples, 1.0), 1.0)


def tile_starts(n: int, points: int, overlap_points: int) -> np.ndarray:
    """First indices of tiles of ``points`` samples every ``points - overlap_points``; the last one
    moved back to end at the edge."""
    starts = list(range(0, n - points + 1, points - overlap_points))
    if starts[-1] + points < n:
        starts.append(n - points)
    return np.asarray(starts, dtype=np.int64)


def plane_fits(tiles: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """The least-squares plane of each tile (n, rows, columns), all at once: on a full grid the
    centred co-ordinates are orthogonal, so the mean and the two slopes separate."""
    _, rows, columns = tiles.shape
    xs = dx * (np.arange(columns) - 0.5 * (columns - 1))
    ys = dy * (np.arange(rows) - 0.5 * (rows - 1))
    mean = tiles.mean(axis=(1, 2))
    # Plain sums, not BLAS products (see roadtex.profiles.trend): the same bits on any thread count.
    slope_x = (np.sum(tiles * xs[None, None, :], axis=(1, 2)) / (rows * float(np.sum(xs * xs)))
               if columns > 1 else np.zeros(len(tiles)))
    slope_y = (np.sum(tiles * ys[None, :, None], axis=(1, 2)) / (columns * float(np.sum(ys * ys)))
               if rows > 1 else np.zeros(len(tiles)))
    return mean[:, None, None] + slope_x[:, None, None] * xs[None, None, :] + slope_y[:, None, None] * ys[None, :, None]


def cut_tiles(surface: Surface, length: float, width: float, overlap: float | tuple[float, float] = 0.0, *,
              detrend: bool = True) -> Tiles:
    """Tiles of ``length`` x ``width`` (m) overlapping by ``overlap`` (m); see :meth:`Surface.tiles`."""
    if np.isnan(surface.heights).any():
        raise InvalidInputError("tiles need a surface without drop-outs: call fill_dropouts() first")
    length_f, width_f = positive(length, "length"), positive(width, "width")
    if isinstance(overlap, (tuple, list)):
        if len(overlap) != 2:
            raise InvalidInputError(f"overlap must be one number or (along, across), got {overlap!r}")
        ox, oy = finite_number(overlap[0], "overlap along"), finite_number(overlap[1], "overlap across")
    else:
        ox = oy = finite_number(overlap, "overlap")
    rows_total, columns_total = surface.shape
    columns = int(round(length_f / surface.dx))
    rows = int(round(width_f / surface.dy))
    if columns < 2 or rows < 1:
        raise InvalidInputError(f"a tile of {length_f:.3g} m x {width_f:.3g} m is less than 2 columns or 1 row "
                                f"at dx {surface.dx:.3g} m, dy {surface.dy:.3g} m")
    if columns > columns_total or rows > rows_total:
        hint = ""
        if surface.width > surface.length:
            hint = (f"; the surface is wider across the road ({rows_total} rows) than long along it ({columns_total} "
                    "columns): is it transposed? heights[iy, ix] has rows across the road and columns along it")
        elif columns > columns_total:
            hint = "; use shorter tiles (the bulk job's --segment-length)"
        raise InvalidInputError(f"a tile of {length_f:.6g} m along the road x {width_f:.6g} m across exceeds the "
                                f"surface ({surface.length:.6g} m along x {surface.width:.6g} m across){hint}")
    ox_points, oy_points = int(round(ox / surface.dx)), int(round(oy / surface.dy))
    if not (0 <= ox_points < columns and 0 <= oy_points < rows):
        raise InvalidInputError(f"overlap must be in [0, tile size) in each direction, got {overlap!r} m "
                                f"for tiles of {length_f!r} m x {width_f!r} m")
    along = tile_starts(columns_total, columns, ox_points)
    across = tile_starts(rows_total, rows, oy_points)
    row_starts = np.repeat(across, along.size)
    column_starts = np.tile(along, across.size)
    take_rows = row_starts[:, None, None] + np.arange(rows)[None, :, None]
    take_columns = column_starts[:, None, None] + np.arange(columns)[None, None, :]
    heights = surface.heights[take_rows, take_columns]
    trends = plane_fits(heights, surface.dx, surface.dy) if detrend else np.zeros_like(heights)
    return Tiles(heights=heights - trends, trends=trends, row_starts=row_starts, column_starts=column_starts,
                 dx=surface.dx, dy=surface.dy, length=columns * surface.dx, width=rows * surface.dy,
                 overlap=(ox_points * surface.dx, oy_points * surface.dy), surface_shape=surface.shape,
                 x0=surface.x0, y0=surface.y0)
