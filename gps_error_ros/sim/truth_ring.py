"""The fix engine's truth history: per-agent rings of (stamp, lat, lon, alt)."""

import numpy as np

from gps_error_ros.model.state import BoolArray, FloatArray, IntArray, Numbers


class TruthRing:
    """Per-agent circular buffers of (stamp, lat, lon, alt)."""

    def __init__(self, n: int, size: int) -> None:
        self.size = size
        self.stamp = np.full((n, size), -1, dtype=np.int64)
        self.coord = np.zeros((n, size, 3))
        self.head = np.zeros(n, dtype=np.int64)      # next slot to write
        self.newest = np.full(n, -1, dtype=np.int64)

    def push(self, agents: IntArray, stamps: IntArray, coords: Numbers) -> None:
        """Store one sample for each of ``agents`` (distinct agent indices)."""
        slot = self.head[agents] % self.size
        self.stamp[agents, slot] = stamps
        self.coord[agents, slot] = coords
        self.head[agents] += 1
        self.newest[agents] = stamps

    def newest_coord(self, rows: IntArray) -> FloatArray:
        """Return the newest sample's coordinates for ``rows``."""
        return self.coord[rows, (self.head[rows] - 1) % self.size]

    def clear(self, rows: IntArray | slice = slice(None)) -> None:
        """Forget every sample (of ``rows``: all by default)."""
        self.stamp[rows] = -1
        self.newest[rows] = -1
        self.head[rows] = 0

    def grow(self, n: int) -> None:
        """Add ``n`` empty rows."""
        self.stamp = np.concatenate([self.stamp, np.full((n, self.size), -1, np.int64)])
        self.coord = np.concatenate([self.coord, np.zeros((n, self.size, 3))])
        self.head = np.concatenate([self.head, np.zeros(n, np.int64)])
        self.newest = np.concatenate([self.newest, np.full(n, -1, np.int64)])

    def interpolate(self, rows: IntArray, t_ns: int,
                    max_gap_ns: int) -> tuple[FloatArray, BoolArray]:
        """
        Return truth at ``t_ns`` for ``rows`` (each must have a sample >= t).

        Returns (coords (m, 3), ok (m,)): ``ok`` is False where no sample at
        or before ``t_ns`` is held.
        """
        stamps = self.stamp[rows]
        valid = stamps >= 0
        after = np.where(valid & (stamps >= t_ns), stamps, np.iinfo(np.int64).max)
        before = np.where(valid & (stamps <= t_ns), stamps, -1)
        i_hi = np.argmin(after, axis=1)
        i_lo = np.argmax(before, axis=1)
        ok = before[np.arange(len(rows)), i_lo] >= 0
        s_lo = stamps[np.arange(len(rows)), i_lo].astype(float)
        s_hi = stamps[np.arange(len(rows)), i_hi].astype(float)
        ok &= (s_hi - s_lo) <= max_gap_ns
        c_lo = self.coord[rows, i_lo]
        c_hi = self.coord[rows, i_hi]
        span = s_hi - s_lo
        w = np.divide(t_ns - s_lo, span, out=np.zeros_like(span), where=span > 0)
        return c_lo + w[:, None] * (c_hi - c_lo), ok
