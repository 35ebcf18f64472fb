"""
Reported speed and course for trajectories (``gps_error simulate`` CSV mode).

The true velocity of each agent comes from its own truth positions: central
differences in east/north metres (one-sided at the ends, zero for an agent
seen once), then taken ``lag_s`` earlier by linear interpolation in time.
The velocity error of each agent is its own stream from the run's first step
(:meth:`Velocity.errors`), indexed by each row's model step, so an agent's
reported speed and course do not depend on the other agents.
"""

import math

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.geodesy import difference


def true_velocity(t, lat, lon):
    """Return east/north velocity (n, 2) of one agent's truth rows (t increasing)."""
    n = t.size
    v = np.zeros((n, 2))
    if n < 2:
        return v
    north, east = difference(lat[1:], lon[1:], lat[:-1], lon[:-1])
    step = np.stack([east, north], axis=1) / np.diff(t)[:, None]
    v[0], v[-1] = step[0], step[-1]
    if n > 2:       # central: the chord from the previous to the next row
        n2, e2 = difference(lat[2:], lon[2:], lat[:-2], lon[:-2])
        v[1:-1] = np.stack([e2, n2], axis=1) / (t[2:] - t[:-2])[:, None]
    return v


def speed_and_course(velocity, seed, data, start_step, rate_hz):
    """
    Return (speed, course, truth_speed, truth_course) per row of ``data``.

    ``data`` as :func:`read_truth_csv` gives it (t, agent, truth_lat,
    truth_lon); the run's first model step is ``start_step``.
    """
    t = data['t']
    agents = np.asarray(data['agent'], dtype=object)
    out = [np.full(t.size, np.nan) for _ in range(4)]
    for name in dict.fromkeys(agents):
        rows = np.flatnonzero(agents == name)
        tt = t[rows]
        vt = true_velocity(tt, data['truth_lat'][rows], data['truth_lon'][rows])
        lagged = np.stack([np.interp(tt - velocity.lag_s, tt, vt[:, a]) for a in range(2)],
                          axis=1)
        steps = np.floor(tt * rate_hz + 1e-9).astype(np.int64) - start_step
        key = np.array([streams.agent_key(seed, name)], dtype=np.uint64)
        w = velocity.errors(key, int(steps.max()) + 1, start=start_step)[steps, 0]
        out[0][rows], out[1][rows] = velocity.report(lagged, w)
        out[2][rows] = np.hypot(vt[:, 0], vt[:, 1])
        course = np.degrees(np.arctan2(vt[:, 0], vt[:, 1])) % 360.0
        out[3][rows] = np.where(out[2][rows] > 0, course, math.nan)
    return tuple(out)
