"""
How far the landmark method's truth is from the walker's true path.

The reference paper took its truth from landmarks and the times the walker
passed them, at constant speed in between. This simulates that on the
Manhattan walker (:mod:`.walker`: blocks at speeds varying by +-15 %, waits
of 5-45 s at half the corners). Two protocols: a landmark at every corner,
or only where the route turns (straight runs of several blocks between
presses, with their speed changes and waits). Pressed on arrival only, a
wait is spread over the next stretch; pressed again on leaving, what
remains is the speed changing between presses (with a landmark at every
corner, nothing in this walker, whose speed is constant within a block).
"""

from collections.abc import Iterable

import numpy as np

from gps_error_ros.model.state import BoolArray, FloatArray
from gps_error_ros.sim.walker import manhattan_walk


def _turns(east: FloatArray, north: FloatArray) -> BoolArray:
    """Return True at the route points where the direction changes (and ends)."""
    d = np.stack([np.diff(east), np.diff(north)], axis=1)
    moving = np.flatnonzero(np.hypot(d[:, 0], d[:, 1]) > 0)
    out = np.zeros(east.size, dtype=bool)
    out[[0, -1]] = True
    for a, b in zip(moving[:-1], moving[1:]):
        if abs(d[a, 0] * d[b, 1] - d[a, 1] * d[b, 0]) > 1e-6:    # not collinear
            out[a + 1] = True
    return out


def landmark_error(seeds: Iterable[int] = range(20), duration: float = 3600,
                   press_on_leaving: bool = False, landmarks: str = 'corners') -> FloatArray:
    """
    Return the distances (m) between the landmark truth and the true path.

    One per second of each walk. ``landmarks``: 'corners' (every corner) or
    'turns' (only where the route turns); passed at arrival and, with
    ``press_on_leaving``, again when leaving after a wait there.
    """
    out = []
    for seed in seeds:
        w = manhattan_walk(duration, np.random.default_rng(seed))
        moved = np.r_[True, (np.diff(w.east) != 0) | (np.diff(w.north) != 0)]
        keep = np.ones_like(moved) if press_on_leaving else moved
        if landmarks == 'turns':
            at_turn = _turns(w.east, w.north)
            # a turn point and, when pressing on leaving, the end of its wait
            same = np.r_[False, (np.diff(w.east) == 0) & (np.diff(w.north) == 0)]
            keep = keep & (at_turn | (same & np.r_[False, at_turn[:-1]]))
        at, e, n = w.t[keep], w.east[keep], w.north[keep]
        t = np.arange(0.0, min(duration, at[-1]))
        te, tn = w.position(t)
        out.append(np.hypot(np.interp(t, at, e) - te, np.interp(t, at, n) - tn))
    return np.concatenate(out)
