"""
Where the device was ``lag_s`` ago: the offsets of the ``motion_lag`` effect.

A receiver that reports where the device was ``lag_s`` seconds ago has an
error, relative to the truth at the stamp, of its noise plus ``truth(t -
lag_s) - truth(t)``. :func:`lag_offsets` gives that term for a whole
trajectory; :class:`LagBuffer` for trajectories streamed one step at a time.
"""

from typing import Iterable, Optional, Sequence

import numpy as np

from gps_error_ros.model.state import FloatArray, Numbers

#: A truth gap longer than this, s, separates two runs (recordings joined one after
#: another are :data:`~gps_error_ros.traces.trace_io.RECORDING_GAP_S` apart): a motion
#: lag, a direction of travel or a velocity's lag never reaches back across it.
RUN_GAP_S = 60.0


def held_across_gaps(t: Numbers, times: Numbers, gap_s: Optional[float]) -> FloatArray:
    """
    Return ``times`` with each one that falls in a gap of ``t`` over ``gap_s`` moved to its end.

    ``t``: the truth's sample times (s, increasing). A gap longer than
    ``gap_s`` separates two runs (two recordings one after another): a time
    inside it is taken as the later run's first sample, whose truth is held
    back to the gap, as before a trajectory's first sample. None: no limit.
    """
    times = np.asarray(times, dtype=float)
    t = np.asarray(t, dtype=float)
    if gap_s is None or t.size < 2:
        return times
    i = np.clip(np.searchsorted(t, times, side='right') - 1, 0, t.size - 2)
    inside = (times > t[i]) & (t[i + 1] - t[i] > gap_s)
    return np.where(inside, t[i + 1], times)


def truth_at(t: Numbers, values: Numbers, when: Numbers,
             gap_s: Optional[float] = None) -> FloatArray:
    """
    Return ``values`` (n, k), sampled at times ``t``, interpolated linearly at ``when``, (m, k).

    Held before the first sample and, with ``gap_s``, before the first
    sample after a gap longer than that (:func:`held_across_gaps`): a time
    never reaches back into the run before.
    """
    when = held_across_gaps(t, when, gap_s)
    values = np.asarray(values, dtype=float)
    return np.stack([np.interp(when, t, values[:, j]) for j in range(values.shape[1])],
                    axis=1)


def lag_offsets(t: Numbers, north: Numbers, east: Numbers, lag_s: float,
                at: Optional[Numbers] = None, gap_s: Optional[float] = None) -> FloatArray:
    """
    Return ``truth(at - lag_s) - truth(at)`` (north, east metres), shape (n, 2).

    The truth is sampled at times ``t`` (s, increasing) as ``north``/``east``
    in a local frame and interpolated linearly; ``at`` defaults to ``t``.
    Before the first sample the truth is held (offset toward the first
    position), and, with ``gap_s``, before the first sample after a gap
    longer than that (:func:`held_across_gaps`).
    """
    t = np.asarray(t, dtype=float)
    at = t if at is None else np.asarray(at, dtype=float)
    out = np.zeros((at.size, 2))
    if lag_s == 0.0 or at.size == 0:
        return out
    ne = np.stack([north, east], axis=1)
    return truth_at(t, ne, at - lag_s, gap_s) - truth_at(t, ne, at)


#: Nanoseconds per second: trajectories' times are taken in integer nanoseconds, as the node's.
NS = 1_000_000_000


def stamp_ns(t: float) -> int:
    """Return time ``t`` (s) in whole nanoseconds, as the node stamps it."""
    return int(round(t * NS))


def between(a: tuple[float, float, float], b: tuple[float, float, float],
            when: int) -> tuple[float, float]:
    """
    Return the position at ``when`` (ns) between samples ``a`` and ``b`` (ns, x, y).

    The node's interpolation of its truth, to the last bit
    (:meth:`~gps_error_ros.sim.truth_ring.TruthRing.interpolate`): the same
    weight from the same nanoseconds and the same arithmetic, so that a
    lagged position and a direction of travel are the node's in ``simulate``.
    """
    span = b[0] - a[0]
    w = (when - a[0]) / span if span > 0 else 0.0
    return a[1] + w * (b[1] - a[1]), a[2] + w * (b[2] - a[2])


class LagBuffer:
    """
    Recent positions per named agent, to report where each was ``lag_s`` ago.

    For trajectories streamed one time step at a time (SUMO FCD): positions
    are kept for ``lag_s`` plus one sample and interpolated linearly in the
    coordinates given; before an agent's first sample its first position is
    held.
    """

    def __init__(self, lag_s: float) -> None:
        self.lag_s = float(lag_s)
        self.lag_ns = int(round(self.lag_s * NS))
        self.hist: dict[str, list[tuple[float, float, float]]] = {}

    def lagged(self, names: Sequence[str], t: float, x: Numbers,
               y: Numbers) -> tuple[FloatArray, FloatArray]:
        """Store (t, x, y) per agent; return the positions ``lag_s`` earlier."""
        ox, oy = np.array(x, dtype=float), np.array(y, dtype=float)
        if self.lag_s == 0.0:
            return ox, oy
        t_ns = stamp_ns(t)
        want = t_ns - self.lag_ns
        for i, n in enumerate(names):
            h = self.hist.setdefault(n, [])
            h.append((float(t_ns), ox[i], oy[i]))
            while len(h) > 2 and h[1][0] <= want:
                h.pop(0)
            if len(h) > 1 and h[0][0] <= want:
                ox[i], oy[i] = between(h[0], h[1], want)
            else:
                ox[i], oy[i] = h[0][1], h[0][2]
        return ox, oy

    def forget(self, names: Iterable[str]) -> None:
        """Drop the history of agents that left."""
        for n in names:
            self.hist.pop(n, None)
