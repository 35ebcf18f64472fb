"""
Reported speed and course for trajectories (``gps_error simulate`` CSV mode).

The true velocity of each agent at time ``t`` is the chord of its truth over
the second centred at ``t`` (positions linear in time between rows; none
where the chord leaves them); what the phone reports uses it at
``t - lag_s``, the chord ending no later than ``t``: the error node's
definition (:mod:`velocity_state`).
The velocity error of each agent is its own stream from the run's first step
(:meth:`Velocity.errors`), indexed by each row's model step, so an agent's
reported speed and course do not depend on the other agents.
"""

import math

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.velocity import course_deg


def true_velocity(t, lat, lon, at, now=None):
    """
    Return east/north m/s at times ``at``: the chord over the second centred there.

    The truth is linear in time between rows, as the error node interpolates
    it; with ``now`` (the rows' own times) a chord never ends after ``now``,
    as the node's never ends after its step. NaN where the chord reaches
    outside the rows (the node reports no velocity there either).
    """
    end = at + 0.5 if now is None else np.minimum(at + 0.5, now)
    la1, lo1 = np.interp(end, t, lat), np.interp(end, t, lon)
    la0, lo0 = np.interp(end - 1.0, t, lat), np.interp(end - 1.0, t, lon)
    north, east = difference(la1, lo1, la0, lo0)
    v = np.stack([np.asarray(east), np.asarray(north)], axis=1)
    v[(end - 1.0 < t[0]) | (end > t[-1])] = np.nan      # the truth does not cover it
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
        lat, lon = data['truth_lat'][rows], data['truth_lon'][rows]
        vt = true_velocity(tt, lat, lon, tt)
        lagged = true_velocity(tt, lat, lon, tt - velocity.lag_s, now=tt)
        steps = np.floor(tt * rate_hz + 1e-9).astype(np.int64) - start_step
        key = np.array([streams.agent_key(seed, name)], dtype=np.uint64)
        w = velocity.errors(key, int(steps.max()) + 1, start=start_step)[steps, 0]
        out[0][rows], out[1][rows] = velocity.report(lagged, w)
        out[2][rows] = np.hypot(vt[:, 0], vt[:, 1])
        out[3][rows] = np.where(out[2][rows] > 0, course_deg(vt), math.nan)
    return tuple(out)
