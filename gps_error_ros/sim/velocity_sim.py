"""
Reported speed and course for trajectories (``gps_error simulate`` CSV mode).

The true velocity of each agent at time ``t`` is the chord of its truth over
the second centred at ``t`` (positions linear in time between rows; none
where the chord leaves them); what the phone reports uses it at
``t - lag_s``, the chord ending no later than ``t`` (and its direction
at ``t - course_lag_s`` where the section has one): the error node's
definition (:mod:`velocity_state`).
The velocity error of each agent is its own stream from the run's first step
(:meth:`Velocity.errors`), indexed by each row's model step, so an agent's
reported speed and course do not depend on the other agents.
"""

from collections.abc import Iterable, Mapping, Sequence
import math
from typing import Any

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.state import FloatArray, Numbers
from gps_error_ros.model.velocity import course_deg, Velocity
from gps_error_ros.sim.velocity_state import SideProcess


def true_velocity(t: FloatArray, lat: FloatArray, lon: FloatArray, at: FloatArray,
                  now: FloatArray | None = None) -> FloatArray:
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


def speed_and_course(velocity: Velocity, seed: int, data: Mapping[str, Any], start_step: int,
                     rate_hz: float) -> tuple[FloatArray, ...]:
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
        lagged = velocity.truth_reported(*(true_velocity(tt, lat, lon, tt - lag, now=tt)
                                           for lag in velocity.lags))
        steps = np.floor(tt * rate_hz + 1e-9).astype(np.int64) - start_step
        key = np.array([streams.agent_key(seed, name)], dtype=np.uint64)
        w = velocity.errors(key, int(steps.max()) + 1, start=start_step)[steps, 0]
        out[0][rows], out[1][rows] = velocity.report(lagged, w)
        out[2][rows] = np.hypot(vt[:, 0], vt[:, 1])
        out[3][rows] = np.where(out[2][rows] > 0, course_deg(vt), math.nan)
    return tuple(out)


def row_values(process: SideProcess, seed: int, agents: Numbers, t: Numbers,
               start_step: int, rate_hz: float) -> FloatArray:
    """
    Return a side stream's value at every row, (rows, d), each agent its own stream.

    ``process`` as :class:`gps_error_ros.sim.velocity_state.SideStream`'s
    (the velocity error, the stated accuracy's fluctuation); every agent's
    stream counts from the run's first model step ``start_step``, as in the
    node, so a row's value does not depend on the other agents.
    """
    names = np.asarray(agents, dtype=object)
    steps = np.floor(np.asarray(t) * rate_hz + 1e-9).astype(np.int64) - start_step
    out: FloatArray | None = None
    for name in dict.fromkeys(names):
        rows = np.flatnonzero(names == name)
        key = np.array([streams.agent_key(seed, name)], dtype=np.uint64)
        w = process.errors(key, int(steps[rows].max()) + 1, start=start_step)[steps[rows], 0]
        if out is None:
            out = np.full((names.size, w.shape[1]), np.nan)
        out[rows] = w
    if out is None:
        raise ValueError('row_values: expected at least one row')
    return out


class StreamTracker:
    """
    A side stream's value for named agents streamed step by step (SUMO FCD).

    What :func:`row_values` gives, one time step at a time: each agent's
    stream counts from the run's first model step; an agent first seen (or
    seen again) later is caught up on its own stream.
    """

    def __init__(self, process: SideProcess, seed: int, start_step: int) -> None:
        self.process, self.seed, self.start = process, seed, int(start_step)
        # name -> (key, step, value (d,))
        self.known: dict[str, tuple[Any, int, FloatArray]] = {}

    def values(self, names: Sequence[str], step: int) -> FloatArray:
        """Return the named agents' values at model step ``step``, (n, d)."""
        rows: list[Any] = [self.known.get(n) for n in names]      # None: not known
        out: list[Any] = [None] * len(names)
        nxt = [i for i, r in enumerate(rows) if r is not None and r[1] == step - 1]
        if nxt:                             # the usual case: one step on, all at once
            keys = np.array([rows[i][0] for i in nxt], dtype=np.uint64)
            stepped = self.process.step(np.array([rows[i][2] for i in nxt]), keys, step)
            for j, i in enumerate(nxt):
                out[i] = stepped[j]
        for i, n in enumerate(names):
            if out[i] is not None:
                continue
            key, last, w = rows[i] or (streams.agent_key(self.seed, n), None, None)
            if last is None or w is None or last > step:
                w = self.process.errors(np.array([key], dtype=np.uint64), step - self.start + 1,
                                        start=self.start)[-1, 0]
            else:
                for k in range(last + 1, step + 1):
                    w = self.process.step(w[None], np.array([key], dtype=np.uint64), k)[0]
            out[i] = w
        for i, n in enumerate(names):
            self.known[n] = (rows[i][0] if rows[i] else streams.agent_key(self.seed, n),
                             step, out[i])
        return np.array(out).reshape(len(names), -1)

    def forget(self, names: Iterable[str]) -> None:
        """Drop agents that left (they are caught up again if they come back)."""
        for n in names:
            self.known.pop(n, None)


class StreamedVelocity:
    """
    Reported speed and course for agents streamed one time step at a time (SUMO FCD).

    The same as :func:`speed_and_course` on the whole file: each agent's
    truth is kept back to the start of the chord the phone reports (the
    second centred at ``t - lag_s``, ending no later than ``t``; and the one
    at ``t - course_lag_s`` where the section has it), linear in time
    between its rows; no velocity (NaN) before the truth reaches back that
    far. The velocity error is the agent's own stream from the run's
    first model step (:class:`StreamTracker`). ``planar``: positions are
    x/y metres (east, north) instead of latitude/longitude.
    """

    def __init__(self, velocity: Velocity, seed: int, planar: bool = False) -> None:
        self.velocity, self.seed, self.planar = velocity, seed, planar
        self.errors: StreamTracker | None = None
        # name -> [first t, [(t, lat, lon), ...]]
        self.hist: dict[str, list[Any]] = {}

    def report(self, names: Sequence[str], t: float, step: int, lat: Numbers,
               lon: Numbers, start: int | None = None) -> tuple[FloatArray, FloatArray]:
        """
        Store each agent's truth at ``t``; return (speed, course) arrays (NaN: none).

        ``start``: the run's first model step (default: the first call's).
        """
        if self.errors is None:
            self.errors = StreamTracker(self.velocity, self.seed, step if start is None else start)
        chords = [min(t - lag + 0.5, t) for lag in self.velocity.lags]   # each chord's end
        earliest = min(chords) - 1.0
        ends: FloatArray = np.full((len(chords), len(names), 4), np.nan)
        for i, n in enumerate(names):
            first, h = self.hist.setdefault(n, [t, []])
            h.append((t, float(lat[i]), float(lon[i])))
            while len(h) > 2 and h[1][0] <= earliest:
                h.pop(0)
            if earliest >= first - 1e-9:
                tt, la, lo = (np.array(c) for c in zip(*h))
                for j, end in enumerate(chords):
                    ends[j, i] = [np.interp(end, tt, la), np.interp(end, tt, lo),
                                  np.interp(end - 1.0, tt, la), np.interp(end - 1.0, tt, lo)]
        v_true = self.velocity.truth_reported(*(self._chord(e) for e in ends))
        return self.velocity.report(v_true, self.errors.values(names, step))

    def _chord(self, ends: FloatArray) -> FloatArray:
        """Return east/north m/s from chord ends (n, 4): lat/lon (or y/x) at its end, start."""
        north: Numbers
        east: Numbers
        if self.planar:                     # (y, x) metres
            north, east = ends[:, 0] - ends[:, 2], ends[:, 1] - ends[:, 3]
        else:
            north, east = difference(ends[:, 0], ends[:, 1], ends[:, 2], ends[:, 3])
        return np.stack([np.asarray(east, dtype=float), np.asarray(north, dtype=float)], axis=1)
