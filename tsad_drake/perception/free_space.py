"""Space the cameras saw through: where a hidden side of an object cannot be.

An object whose back is hidden behind itself or a neighbour has an unknown extent away from the
camera. A point in the shelf is *seen free* when some view's reading along the ray through it lies
beyond it (the ray passed the point and hit something farther on); a reading in front of it, or
none (dropout), says nothing. `fit_box` grows an unseen box end into the shelf until it would
cover seen-free space or reach the largest object size, instead of assuming the smallest box.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np


@dc.dataclass
class FreeSpace:
    """Depth images with their camera poses, queried for seen-free points."""

    depths: list[np.ndarray]  #: (H, W) m per view, inf where nothing was read
    poses: list[np.ndarray]  #: 4x4 X_SC per view
    intrinsics: np.ndarray  #: 3x3 pinhole matrix shared by the views
    margin: float = 0.01  #: m, a reading must lie this far beyond a point to clear it

    def seen_free(self, points: np.ndarray) -> np.ndarray:
        """(N,) True where some view read a surface more than `margin` beyond the point."""
        points = np.atleast_2d(np.asarray(points, dtype=float))
        free = np.zeros(len(points), dtype=bool)
        fx, fy = self.intrinsics[0, 0], self.intrinsics[1, 1]
        cx, cy = self.intrinsics[0, 2], self.intrinsics[1, 2]
        for depth, X_SC in zip(self.depths, self.poses, strict=True):
            p_C = (points - X_SC[:3, 3]) @ X_SC[:3, :3]
            z = p_C[:, 2]
            ahead = z > 1e-6
            u = np.full(len(points), -1, dtype=int)
            v = np.full(len(points), -1, dtype=int)
            u[ahead] = np.round(p_C[ahead, 0] / z[ahead] * fx + cx).astype(int)
            v[ahead] = np.round(p_C[ahead, 1] / z[ahead] * fy + cy).astype(int)
            inside = ahead & (u >= 0) & (u < depth.shape[1]) & (v >= 0) & (v < depth.shape[0])
            reading = np.full(len(points), np.nan)
            reading[inside] = depth[v[inside], u[inside]]
            with np.errstate(invalid="ignore"):
                free |= np.isfinite(reading) & (reading > z + self.margin)
        return free
